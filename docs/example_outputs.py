"""The examples of the README and the user guide, run, and what they print
stored: the outputs the docs quote.

Every fenced code block of README.md and the user-guide pages (docs/*.md,
in the order of the docs' table of contents) is run in the order a reader
meets them, in one scratch folder: ``python`` blocks in one interpreter
namespace, ``bash`` blocks by bash with this environment's ``bayescal`` and
``python`` first on the PATH. A block after ``<!-- skip: REASON -->`` is not
run; one after ``<!-- needs: PATH -->`` runs only when ``PATH`` (relative to
the repository's parent, e.g. ``../shared/data``) exists. The same block
text met again is run once.

``python docs/example_outputs.py`` runs them all, writes what each block
printed into ``docs/gallery/outputs.json`` (keyed by the block's text) and
the result files prose quotes (:data:`SAVED`) into ``docs/gallery/``, then
rewrites every quoted output line of the pages (a ``text`` block after a
block that ran) as the stored line that says the same, and every number of
``docs/quoted.toml`` from its stored result (``--no-run``: only the
rewriting), and every table marked on a page from its stored results
(:mod:`tables`, ``docs/tables.toml``). The example scripts of :data:`SCRIPTS` run too, and the
files they write that the docs quote are stored the same way.
``tests/test_doc_numbers.py`` checks each quoted line and
number against the stored ones, and ``tests/test_docs.py`` runs the
examples again and checks each quoted line's words against the live
output.
"""
from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import tables  # noqa: E402  (docs/tables.py)

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: README, then the user-guide pages in the order of the docs' table of contents.
GUIDE = ["index", "install", "fit", "report", "diagnose", "windows", "noise", "cal", "uvw",
         "batch", "python", "science", "gallery"]
PAGES = [ROOT / "README.md", *[DOCS / f"{name}.md" for name in GUIDE]]
#: The stored outputs the pages quote.
STORED = DOCS / "gallery" / "outputs.json"
#: The numbers quoted in prose: each with its stored result and entry.
QUOTED = DOCS / "quoted.toml"
#: Files the examples write that prose quotes (written in the scratch folder
#: -> stored under docs/gallery/).
SAVED = {"cowi/result.json": "cowi_result.json"}
#: Example scripts whose results prose quotes: script -> (the data it needs,
#: {file it writes under its --out: stored under docs/gallery/ as}).
SCRIPTS = {"examples/real_huddle.py": ("../shared/data/real/obspy_relcal",
                                       {"fit/result.json": "huddle_result.json",
                                        "comparison.json": "huddle_comparison.json"})}
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def blocks(path):
    """(lang, body, skip reason or None, needed path or None, line) of each
    fenced code block of ``path``; MyST directives (```{toctree}) are not
    code and are left out."""
    out, lines, i = [], Path(path).read_text().splitlines(), 0
    while i < len(lines):
        m = re.match(r"^(`{3,})(.*)$", lines[i])
        if not m:
            i += 1
            continue
        fence, info, start = m.group(1), m.group(2).strip(), i
        j = i + 1
        while j < len(lines) and lines[j].strip() != fence:
            j += 1
        if not info.startswith("{"):
            marks = lines[start - 1] if start else ""        # the line just above
            skip = re.search(r"<!-- skip: ([^>]*?) -->", marks)
            needs = re.search(r"<!-- needs: ([^>]*?) -->", marks)
            out.append((info, "\n".join(lines[start + 1:j]) + "\n", skip and skip.group(1),
                        needs and needs.group(1), start + 1))
        i = j + 1
    return out


def mask(line):
    """``line`` with its numbers masked and its spaces collapsed: what an
    output line says, whatever the run's numbers."""
    return " ".join(NUMBER.sub("#", line).split())


def key(body):
    """The stored outputs' key of a block: a digest of its text."""
    return hashlib.sha256(body.encode()).hexdigest()[:16]


def quoted(pages=PAGES):
    """``(page, line, block text, quoted text)`` of every ``text`` block that
    follows a block that runs: the output the page shows for that block."""
    out = []
    for page in pages:
        last = None
        for lang, body, skip, _, line in blocks(page):
            if lang == "text" and last is not None:
                out.append((page, line, last, body))
            last = body if lang in ("python", "bash") and not skip else None
    return out


def run_block(lang, body, namespace, env, where):
    """Run one block; returns what it printed (stdout and stderr)."""
    code = body.replace("../shared/", f"{ROOT.parent}/shared/")
    if lang == "python":
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
            exec(compile(code, where, "exec"), namespace)
        return buf.getvalue()
    proc = subprocess.run(["bash", "-e", "-c", code], capture_output=True, text=True, env=env,
                          timeout=1800)
    if proc.returncode:
        raise RuntimeError(f"{where}:\n{code}\n{proc.stderr}")
    return proc.stdout + proc.stderr


def run_pages(folder, pages=PAGES, strict_data=False):
    """Run every block of ``pages`` in ``folder``: ``(printed, skipped)``,
    ``printed`` the block text -> what it printed, ``skipped`` the
    ``(where, why)`` of each block not run."""
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
               MPLBACKEND="Agg", PYTHONPATH=str(ROOT))
    namespace = {"__name__": "__docs__"}
    printed, skipped = {}, []
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        for page in pages:
            for lang, body, skip, needs, line in blocks(page):
                where = f"{Path(page).relative_to(ROOT)}:{line}"
                if lang == "text" or body in printed:
                    continue
                if skip:
                    skipped.append((where, skip))
                elif needs and not (ROOT.parent / needs.removeprefix("../")).exists():
                    skipped.append((where, f"{needs} absent"))
                else:
                    printed[body] = run_block(lang, body, namespace, env, where)
    finally:
        os.chdir(cwd)
    return printed, skipped


def refresh_page(page, stored):
    """Rewrite each quoted output line of ``page`` as the stored output line
    that says the same (:func:`mask`); returns the lines not found."""
    lines = Path(page).read_text().split("\n")
    missing = []
    for _, line, block, shown in quoted([page]):
        entry = stored.get(key(block))
        printed = [ln.rstrip() for ln in entry["printed"].splitlines()] if entry else []
        masks, pos = [mask(ln) for ln in printed], 0
        for i in range(line, line + len(shown.splitlines())):
            text = lines[i]
            if text.strip() in ("", "...") or text.lstrip().startswith("$ "):
                continue
            # of the lines saying the same, the one sharing most words with
            # the quoted one (a row's label, a channel's id), then the first
            # after the last one matched
            order = [*range(pos, len(printed)), *range(pos)]
            found = sorted((j for j in order if masks[j] == mask(text)),
                           key=lambda j: (-len(set(printed[j].split()) & set(text.split())),
                                          order.index(j)))
            if found:
                lines[i], pos = printed[found[0]], found[0] + 1
            else:
                missing.append(f"{Path(page).name}:{i + 1}: {text.strip()}")
    Path(page).write_text("\n".join(lines))
    return missing


def quoted_value(quote):
    """A ``[[quote]]`` of :data:`QUOTED` formatted from its stored results:
    ``format`` filled, in order, with the entry at ``path`` of each
    ``source`` (``{0[median]:.2f}``). ``source`` is one file or a list;
    with a list, ``path`` is one path for all or a list of paths, one each.
    With ``sources`` (short name -> file) instead, ``format`` is a template
    as a table's row (:mod:`tables`): ``{cov.table.all.inside}``."""
    if "sources" in quote:
        return tables.fill(quote["format"], tables.load(quote["sources"]))
    sources = quote["source"] if isinstance(quote["source"], list) else [quote["source"]]
    paths = quote["path"] if quote["path"] and isinstance(quote["path"][0], list) \
        else [quote["path"]] * len(sources)
    values = []
    for source, path in zip(sources, paths):
        data = json.loads((ROOT / source).read_text())
        for step in path:
            data = data[step]
        values.append(data)
    return quote["format"].format(*values)


def words_of(text):
    """A pattern of ``text`` whatever its line breaks and spaces."""
    return re.compile(r"\s+".join(map(re.escape, text.split())))


def respaced(new, old):
    """``new`` laid out as ``old`` is (its line breaks kept) when both have
    as many words; ``new`` itself otherwise."""
    words, gaps = new.split(), re.findall(r"\s+", old.strip())
    if len(words) != len(old.split()):
        return new
    return words[0] + "".join(gap + word for gap, word in zip(gaps, words[1:]))


def refresh_quotes():
    """Rewrite each number of :data:`QUOTED` on its page and in the file
    from its stored result; returns the quotes not found on their page."""
    import tomllib

    text, missing = QUOTED.read_text(), []
    quotes = tomllib.loads(text)["quote"]
    values = [quoted_value(quote) for quote in quotes]      # all, before any page is written
    for quote, new in zip(quotes, values):
        page = ROOT / quote["page"]
        body = page.read_text()
        if not words_of(quote["text"]).search(body):
            missing.append(f"{quote['page']}: {quote['text']}")
            continue
        page.write_text(words_of(quote["text"]).sub(lambda m: respaced(new, m.group(0)), body,
                                                    count=1))
        text = text.replace(f"text = {json.dumps(quote['text'])}", f"text = {json.dumps(new)}")
    QUOTED.write_text(text)
    return missing


def run_scripts(folder):
    """Run each of :data:`SCRIPTS` whose data are present, its ``--out`` in
    ``folder``, and store the files it wrote under docs/gallery/; returns
    the scripts not run."""
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(ROOT))
    not_run = []
    for script, (needs, saved) in SCRIPTS.items():
        if not (ROOT.parent / needs.removeprefix("../")).exists():
            not_run.append(f"{script} ({needs} absent)")
            continue
        out = Path(folder) / Path(script).stem
        proc = subprocess.run([sys.executable, str(ROOT / script), "--out", str(out)],
                              capture_output=True, text=True, env=env, timeout=3600)
        if proc.returncode:
            raise RuntimeError(f"{script}:\n{proc.stderr}")
        for src, dst in saved.items():
            (DOCS / "gallery" / dst).write_bytes((out / src).read_bytes())
    return not_run


def main(argv=None):
    """Run the examples, write :data:`STORED` and the :data:`SAVED` files,
    and rewrite the pages' quoted outputs and numbers from them."""
    p = argparse.ArgumentParser(description="Run the docs' examples, store what they print "
                                "and rewrite the numbers the pages quote from it.")
    p.add_argument("--no-run", action="store_true",
                   help="only rewrite the pages from the stored outputs")
    a = p.parse_args(argv)
    if not a.no_run:
        with tempfile.TemporaryDirectory() as tmp:
            printed, skipped = run_pages(tmp)
            for src, dst in SAVED.items():
                if (Path(tmp) / src).is_file():
                    (DOCS / "gallery" / dst).write_bytes((Path(tmp) / src).read_bytes())
            skipped += [(script, "not run") for script in run_scripts(tmp)]
        stored = {key(body): {"block": body, "printed": text.replace(tmp, "<scratch>")}
                  for body, text in printed.items()}
        STORED.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")
        for where, why in skipped:
            print(f"not run: {where} ({why})")
        print(f"{len(stored)} blocks' outputs written to {STORED}")
    stored = json.loads(STORED.read_text())
    missing = [m for page in PAGES for m in refresh_page(page, stored)] + refresh_quotes()
    missing += tables.refresh_tables()
    for m in missing:
        print(f"not rewritten (no stored output says it): {m}")


if __name__ == "__main__":
    main()
