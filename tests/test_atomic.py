"""Files and output folders are never seen half written
(:mod:`bayescal.atomic`), and a report's pages are written by one loop
(:func:`bayescal.report.layout.write_pages`)."""
import json
import os
import pathlib

import numpy as np
import pytest

from bayescal.atomic import MANIFEST, atomic_path, replace_folder, staging, write_json


class Boom(Exception):
    pass


def test_atomic_path_writes_on_success_and_nothing_on_error(tmp_path):
    path = tmp_path / "samples.npz"
    with atomic_path(path) as tmp:
        assert os.path.dirname(tmp) == str(tmp_path) and tmp.endswith(".npz")
        np.savez(tmp, x=np.arange(3))           # savez keeps a name ending in .npz
    assert os.listdir(tmp_path) == ["samples.npz"]
    assert np.array_equal(np.load(path)["x"], [0, 1, 2])
    with pytest.raises(Boom), atomic_path(path) as tmp:
        np.savez(tmp, x=np.arange(5))
        raise Boom
    assert os.listdir(tmp_path) == ["samples.npz"]            # no temporary left behind
    assert np.array_equal(np.load(path)["x"], [0, 1, 2])      # the old file untouched
    with pytest.raises(Boom), atomic_path(tmp_path / "new.json"):
        raise Boom                                            # nothing written: nothing there
    assert os.listdir(tmp_path) == ["samples.npz"]


def test_write_json(tmp_path):
    write_json(tmp_path / "a.json", {"x": [1, 2.5]})
    assert json.loads((tmp_path / "a.json").read_text()) == {"x": [1, 2.5]}
    assert os.listdir(tmp_path) == ["a.json"]


def test_staging_publishes_complete_folders_only(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(Boom), staging(out) as tmp:
        pathlib.Path(tmp, "result.json").write_text("{}")
        raise Boom
    assert os.listdir(tmp_path) == []                  # no output, no staging folder
    with staging(out) as tmp:
        for name in ("a.txt", "b.txt"):
            pathlib.Path(tmp, name).write_text(name)
    assert sorted(os.listdir(out)) == [MANIFEST, "a.txt", "b.txt"]
    assert os.listdir(tmp_path) == ["out"]
    (out / "mine.txt").write_text("the user's")
    with staging(out) as tmp:                          # a rerun that writes only b.txt
        pathlib.Path(tmp, "b.txt").write_text("again")
    assert sorted(os.listdir(out)) == [MANIFEST, "b.txt", "mine.txt"]
    assert (out / "b.txt").read_text() == "again"
    assert (out / MANIFEST).read_text() == "b.txt\n"
    with pytest.raises(Boom), staging(out) as tmp:     # a failed rerun changes nothing
        pathlib.Path(tmp, "b.txt").write_text("half")
        raise Boom
    assert (out / "b.txt").read_text() == "again" and os.listdir(tmp_path) == ["out"]


def test_staging_replacing_a_whole_folder(tmp_path):
    out, within = tmp_path / "item", tmp_path / ".tmp"
    out.mkdir()
    (out / "error.json").write_text("{}")
    with staging(out, finish=replace_folder, within=within) as tmp:
        pathlib.Path(tmp, "result.json").write_text("{}")
    assert os.listdir(out) == ["result.json"] and os.listdir(within) == []


def test_write_pages_one_pdf_page_per_figure(tmp_path):
    import pypdf
    from matplotlib.figure import Figure
    from PIL import Image

    from bayescal.report.layout import write_pages

    def figures(fail=False):
        for k in range(3):
            if fail and k == 2:
                raise Boom
            yield (str(tmp_path / f"p{k}.png") if k != 1 else None), Figure(figsize=(4, 3))
    pngs = write_pages(figures(), str(tmp_path / "r.pdf"), page=(5, 4), dpi=50)
    assert pngs == [str(tmp_path / "p0.png"), str(tmp_path / "p2.png")]
    pages = pypdf.PdfReader(str(tmp_path / "r.pdf")).pages
    assert [(float(p.mediabox.width), float(p.mediabox.height)) for p in pages] == [(360, 288)] * 3
    img = Image.open(tmp_path / "p0.png")
    assert img.mode == "L" and img.size == (200, 150)           # greyscale, 4 x 3 in at 50 dpi
    write_pages(figures(), str(tmp_path / "c.pdf"), dpi=50, grey=False)
    assert Image.open(tmp_path / "p0.png").mode == "RGBA"
    assert len(pypdf.PdfReader(str(tmp_path / "c.pdf")).pages) == 3
    before = sorted(os.listdir(tmp_path))
    with pytest.raises(Boom):
        write_pages(figures(fail=True), str(tmp_path / "x.pdf"))
    assert sorted(os.listdir(tmp_path)) == before                # no x.pdf, no temporary
