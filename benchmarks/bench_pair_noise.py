"""Cost of the pair fit's self-noise product (bayescal.core.selfnoise.pair_noise),
which runs in every fit, against the fit it is part of.

    python benchmarks/bench_pair_noise.py [--repeats 5] [--out DIR]

The demo's pair shape (2 h, 20 Hz, 3+3 channels, simulate_pair defaults,
the band chosen from the data); the fit is timed once (``calibrate``,
spectra and sampling included) and ``pair_noise.for_fit`` ``--repeats``
times, median quoted. With ``--out`` the result folder and report are
written there for a look at the self-noise page.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    from bayescal.core.selfnoise import pair_noise
    from bayescal.pair.workflow import calibrate
    from bayescal.io.result import write_results
    from bayescal.simulate.pair import simulate_pair

    p = simulate_pair(seed=0, sut_azimuth=(3.0, 93.0, 0.0))
    t0 = time.perf_counter()
    post = calibrate(sut=p.sut, sut_xml=p.sut_inventory, ref=p.ref, ref_xml=p.ref_inventory, progress=False)
    fit_s = time.perf_counter() - t0
    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        pair_noise.for_fit(post.state.model, post.state.full_samples)
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    sp = post.state.model.spectra
    print(f"pair: {sp.n_u}+{sp.n_r} channels, {sp.n_bands} bands, {sp.freqs.size} bins, "
          f"{sp.n_segments} segments, {len(post.state.full_samples)} posterior samples")
    print(f"whole fit (calibrate, incl. self-noise): {fit_s:.2f} s")
    print(f"self-noise product: median {1000 * med:.0f} ms over {args.repeats} "
          f"(min {1000 * min(times):.0f}, max {1000 * max(times):.0f}); "
          f"{100 * med / fit_s:.1f} % of the fit")
    print("sensor order:", post.sensor_order)
    if args.out:
        from bayescal.report.fit import write_report
        write_results(post, args.out)
        write_report(args.out)
    return np.array(times)


if __name__ == "__main__":
    main()
