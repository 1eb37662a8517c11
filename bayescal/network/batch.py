"""Calibrate a whole network: many SUT/reference pairs on Dask, resumable.

    >>> from bayescal.network.plan import sds_plan
    >>> from bayescal.network.batch import run_batch
    >>> items = sds_plan("archive/", "stationxml/")        # one item per station-day
    >>> summary = run_batch(items, "out/", seed=1)         # LocalCluster, all cores

Each item runs the ordinary pipeline (:func:`bayescal.pair.workflow.calibrate_files`
for CSV items, :func:`bayescal.pair.workflow.calibrate` on ObsPy's SDS reader for
archive items) on a Dask worker and writes its result
folder ``out/<label>/`` (``result.json``, ``samples.npz``, ``diagnostics.npz``,
``sut_corrected.xml`` as ``bayescal fit`` writes them, and ``item.json``)
*atomically*: everything goes to a temporary folder under ``out/.tmp/`` that
is renamed into place only when complete. A failing item writes
``out/<label>/error.json`` (its one-line message) the same way and does not
stop the others.

Resuming: a rerun skips every item whose ``result.json`` exists, retries the
failed ones and clears temporary folders a killed run left behind. What is
sent to a worker is the item (paths and options) and the output folder; the
worker reads the recordings itself, so workers must see the same file system.

Seeds: an item's seed is derived from the global seed and its label
(:func:`item_seed`, a stable hash), so results do not depend on which worker
runs which item, nor on how many there are.
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import socket
import time
import uuid
import warnings

from ..atomic import replace_folder, staging
from ..io.result import save_posterior, write_json

LOG = "batch_log.jsonl"
TMP = ".tmp"


def item_seed(global_seed, label):
    """A 32-bit seed from the global seed and the item label (stable across
    processes and machines, unlike Python's ``hash``)."""
    digest = hashlib.sha256(f"{int(global_seed)}:{label}".encode()).digest()
    return int.from_bytes(digest[:4], "little")


def item_status(out, label):
    """"done", "failed" or "todo" from what is on disk."""
    folder = os.path.join(out, label)
    if os.path.isfile(os.path.join(folder, "result.json")):
        return "done"
    if os.path.isfile(os.path.join(folder, "error.json")):
        return "failed"
    return "todo"


def run_item(item, out):
    """Run one item (on a worker): read, calibrate, save atomically.

    Returns a small dict (label, status, seconds, cpu_seconds of this
    thread, worker, error); never
    raises for a problem of the item itself.
    """
    from ..errors import ModelMisfitWarning, NotConvergedWarning
    from ..io.result import write_corrected_result

    t, cpu = time.time(), time.thread_time()
    opts = {"band": None if item["band"] is None else tuple(item["band"]),
            "fit_response": item["fit_response"], "seed": item["seed"], "progress": False,
            "label": item["label"]}
    try:
        with _item_folder(out, item) as tmp:
            with warnings.catch_warnings():      # both recorded in the batch's table instead
                warnings.filterwarnings("ignore", category=ModelMisfitWarning)
                warnings.filterwarnings("ignore", category=NotConvergedWarning)
                post, sut_inv = _fit_item(item, opts)
            save_posterior(post, tmp)
            if sut_inv is not None and not isinstance(sut_inv, str):
                write_corrected_result(sut_inv, post, os.path.join(tmp, "sut_corrected.xml"))
            seconds, cpu = time.time() - t, time.thread_time() - cpu
            write_json(os.path.join(tmp, "item.json"),
                       {**item, "seconds": seconds, "cpu_seconds": cpu})
    except Exception as exc:   # recorded, never fatal to the batch
        return record_error(item, out, exc, time.time() - t)
    return {"label": item["label"], "status": "done", "seconds": seconds, "cpu_seconds": cpu,
            "worker": f"{socket.gethostname()}:{os.getpid()}", "error": None}


def _item_folder(out, item):
    """The staging folder of an item's result folder ``out/<label>/``: made
    under ``out/.tmp/``, replacing the folder as a whole when complete."""
    return staging(os.path.join(out, item["label"]), finish=replace_folder,
                   within=os.path.join(out, TMP))


def record_error(item, out, exc, seconds=0.0):
    """Publish ``out/<label>/error.json`` (the message's first line; the
    exception's class name only when it has no message) and ``item.json``
    atomically; returns the item's status dict."""
    error = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    with _item_folder(out, item) as tmp:
        write_json(os.path.join(tmp, "error.json"), {"label": item["label"], "error": error})
        write_json(os.path.join(tmp, "item.json"), {**item, "seconds": seconds})
    return {"label": item["label"], "status": "failed", "seconds": seconds,
            "worker": f"{socket.gethostname()}:{os.getpid()}", "error": error}


def _time(value):
    from obspy import UTCDateTime
    return None if value in (None, "") else UTCDateTime(value)


def _client(scheduler, workers, processes):
    from distributed import Client, LocalCluster
    if scheduler:
        return Client(scheduler), None
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                           processes=processes, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster


def run_batch(items, out, *, seed=0, scheduler=None, workers=None, processes=True, quiet=False,
              threshold_deg=2.0, gain_threshold_pct=2.0, report=True, paper="a4"):
    """Run every unfinished item of a plan on Dask and write the tables and report.

    Parameters
    ----------
    items : plan items (:mod:`bayescal.network.plan`).
    out : output folder (created).
    seed : global seed; an item without its own seed gets :func:`item_seed`.
    scheduler : address of a running ``distributed`` scheduler; if None, a
        ``LocalCluster`` of ``workers`` single-threaded workers (default: one
        per core) is started and closed here.
    processes : local workers as processes (True) or threads of this process.
    quiet : no progress bar.
    threshold_deg, gain_threshold_pct : flagging thresholds of the report.
    paper : page size of the report, "a4" or "letter".

    Returns a dict: counts of ``computed``, ``skipped``, ``failed`` items and
    the paths of ``results.csv`` and the report.
    """
    from ..report.batch import results_table, write_report

    os.makedirs(out, exist_ok=True)
    shutil.rmtree(os.path.join(out, TMP), ignore_errors=True)   # left by a killed run
    items = [dict(it, seed=item_seed(seed, it["label"]) if it.get("seed") is None else it["seed"])
             for it in items]
    todo = [it for it in items if item_status(out, it["label"]) != "done"]
    skipped = [it["label"] for it in items if item_status(out, it["label"]) == "done"]
    _log(out, [{"event": "start", "items": len(items), "todo": len(todo), "seed": seed}]
         + [{"event": "skipped", "label": lb} for lb in skipped])
    counts = {"computed": 0, "failed": 0, "skipped": len(skipped)}
    if todo:
        client, cluster = _client(scheduler, workers, processes)
        try:
            for res in _run_on(client, todo, out, quiet):
                counts["computed" if res["status"] == "done" else "failed"] += 1
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    shutil.rmtree(os.path.join(out, TMP), ignore_errors=True)
    table = results_table(items, out)
    summary = {**counts, "results": table}
    if report:
        summary.update(write_report(table, out, threshold_deg=threshold_deg,
                                    gain_threshold_pct=gain_threshold_pct, paper=paper))
    return summary


def _run_on(client, todo, out, quiet):
    """Submit the items ``todo`` to ``client``; yield each one's status
    dict as it finishes (logged, and shown on the progress bar)."""
    from distributed import as_completed

    futures = [client.submit(run_item, it, os.path.abspath(out), pure=False,
                             key=f"bayescal-item-{it['label']}-{uuid.uuid4().hex[:6]}")
               for it in todo]
    bar = None
    if not quiet:
        from tqdm.auto import tqdm
        # disable=None: a bar on a terminal, none in a log
        bar = tqdm(total=len(todo), unit="pair", desc="calibrating", disable=None)
    by_key = {fut.key: it for fut, it in zip(futures, todo)}
    for fut in as_completed(futures):
        try:
            res = fut.result()
        except Exception as exc:   # the worker died (memory, crash...)
            res = record_error(by_key[fut.key], os.path.abspath(out), exc)
        _log(out, [{"event": res["status"], **res}])
        if bar is not None:
            bar.update(1)
            if res["error"]:
                bar.write(f"{res['label']}: {res['error']}")
        yield res
    if bar is not None:
        bar.close()


def _log(out, records):
    """Append JSON lines to ``out/batch_log.jsonl`` (written by the client only)."""
    with open(os.path.join(out, LOG), "a") as fh:
        for r in records:
            fh.write(json.dumps({"time": time.strftime("%Y-%m-%dT%H:%M:%S"), **r}) + "\n")


def read_log(out):
    """The batch log as a list of dicts."""
    path = os.path.join(out, LOG)
    if not os.path.exists(path):
        return []
    with open(path) as fh:
        return [json.loads(line) for line in fh if line.strip()]


def _fit_item(item, opts):
    """The posterior of one plan item and the SUT's inventory (for the
    corrected StationXML)."""
    from ..pair.workflow import calibrate, calibrate_files
    from .plan import read_sds_item

    if item["kind"] == "files":
        post = calibrate_files(ref=item["ref"], ref_xml=item["ref_xml"], sut=item["sut"],
                               sut_xml=item["sut_xml"],
                               start=item.get("start"), end=item.get("end"),
                               sut_id=item.get("sut_id"), ref_id=item.get("ref_id"), **opts)
        return post, post.sut_inventory
    sut, ref, inv, sut_src, ref_src = read_sds_item(item)
    post = calibrate(ref=ref, ref_xml=inv, sut=sut, sut_xml=inv, start=_time(item.get("start")),
                     end=_time(item.get("end")), sut_source=sut_src, ref_source=ref_src, **opts)
    return post, inv.select(network=item["network"], station=item["station"],
                            location=item["sut_location"])
