"""The numbers the README quotes for the pair fit's self-noise
(bayescal.core.selfnoise.pair_noise) beyond tests/test_pair_noise.py: standardised
errors of the estimates (self-noise shaped like the ground motion, the
simulator's default, and white in counts; gains held and the default fit),
sensor-order margins of equal-noise pairs, and the swap check under each
fit mode. About 1 minute.

    python validation/studies/pair_noise_study.py

Pairs: simulate_pair, 1 h at 10 Hz, band 0.02-1 Hz.
"""
from __future__ import annotations

import numpy as np


#: the pairs' record (as tests/test_pair_noise.py simulates them)
SIM = dict(duration=3600.0, fs=10.0)
#: seeds of the standardised-error rows
SEEDS = (3, 5, 6, 7, 8, 9)


def main():
    from bayescal.core.selfnoise import pair_noise
    from bayescal.pair.workflow import calibrate
    from bayescal.simulate.harness import band_noise_truth
    from bayescal.simulate.pair import simulate_pair

    def fit(seed, coh, rcoh, **kw):
        counts = kw.pop("noise_in_counts", False)
        p = simulate_pair(**SIM, seed=seed, coherence=coh, ref_coherence=rcoh,
                          noise_in_counts=counts)
        return p, calibrate(sut=p.sut, sut_xml=p.sut_inventory, ref=p.ref, ref_xml=p.ref_inventory, band=(0.02, 1.0),
                            progress=False, **kw)

    # every fit names its settings (the fit's defaults are gains free and
    # --ref-noise estimate for 3+3 pairs), so a change of default does not
    # silently change what a row measures
    for counts in (False, True):
        for label, kw in [("gains held, quiet", {"fit_response": "none", "ref_noise": "quiet"}),
                          ("gains held, estimate", {"fit_response": "none",
                                                    "ref_noise": "estimate"}),
                          ("default (gains free, estimate)", {})]:
            zs = []
            for seed in SEEDS:
                sim = dict(SIM, seed=seed, coherence=0.99, ref_coherence=0.99)
                p, post = fit(seed, 0.99, 0.99, noise_in_counts=counts, **kw)
                truth = band_noise_truth(post.state.model.spectra,
                                    dict(sim, noise_in_counts=True) if counts else sim)
                r = pair_noise.pair_self_noise(post.state.model, np.median(post.state.full_samples, 0),
                                               post.state.full_samples)
                zs.append((r["psd"] - truth) / r["sd"])
            zs = np.array(zs)
            print(f"standardised error, noise {'white in counts' if counts else 'ground-shaped'}, "
                  f"{label}, seeds {SEEDS} (both coherence 0.99): mean {np.nanmean(zs):+.2f}, "
                  f"sd {np.nanstd(zs):.2f}, inside 90 %: "
                  f"{int(np.sum(np.abs(zs) < 1.645))} of {zs.size}", flush=True)
    for label, kw in [("gains held, quiet", {"fit_response": "none", "ref_noise": "quiet"}),
                      ("default", {})]:
        margins = [fit(seed, 0.99, 0.99, **kw)[1].sensor_order["reference_minus_sut_db"]
                   for seed in range(10, 18)]
        print(f"equal-noise margins (dB), {label}, seeds 10-17:", np.round(margins, 2),
              "flags:", sum(m > pair_noise.SWAP_MARGIN_DB for m in margins))
    print("swapped pair (reference 20.5 dB noisier), seed 3:")
    for label, kw in [("gains nominal, quiet", {"fit_response": "none", "ref_noise": "quiet"}),
                      ("gains free, quiet", {"fit_response": "gain", "ref_noise": "quiet"}),
                      ("gains free, estimate", {"fit_response": "gain", "ref_noise": "estimate"}),
                      ("gains free, estimate, noise white in counts",
                       {"fit_response": "gain", "ref_noise": "estimate",
                        "noise_in_counts": True})]:
        order = fit(3, 0.999, 0.9, **kw)[1].sensor_order
        print(f"  {label:45s} margin {order['reference_minus_sut_db']:+.1f} dB, "
              f"flag {order['reference_noisier']}")


if __name__ == "__main__":
    main()
