"""Model criticism: fit, locate the mismatch between model and recordings,
name the physics left out, model it and show the fit improve.

Same inputs as ``bayescal fit``. Writes into DIR:

  diagnosis.json   schema bayescal.diagnose/1: where the base model misfits
                   (bands, channels, p-values), the effects found with
                   their parameters (95 % intervals) and BIC gains, the
                   per-band misfit before and after, and the base and final
                   fits (result.json contents)
  result.json, samples.npz, diagnostics.npz
                   the final fit (with the effects modelled)
  diagnosis.pdf, diagnosis.png
                   one page saying it in words (unless --no-report)

On stderr (unless --quiet), the search for effects in rounds: each round
scores every effect of the catalogue against the model so far by its BIC
gain and keeps the best one when the gain exceeds 10 (very strong
evidence); the others are scored again in the following round, with the kept
effect in the model. The search stops when no gain exceeds 10 or three
effects are kept. On stdout, the finding in sentences: the effects named,
where the misfit goes, and every estimate that moves by more than 0.3 of
the fit's standard deviations, largest first.

Example:
  bayescal diagnose --ref REF.mseed --ref-xml REF.xml --sut SUT.mseed \\
                    --sut-xml SUT.xml --out diag --band 0.02 3

Exit codes: 0 success; 2 bad input (one line naming the file and the problem;
nothing is written to DIR); 3 results written, but a sampler stopped at
--max-steps before meeting its convergence rule (a NOT CONVERGED line says
which; its intervals are provisional).
"""
from __future__ import annotations

import os
import sys

from .common import (add_pair_arguments, convergence_exit, priors_from,
                     quiet_convergence_warnings, staging)

HELP = "locate model/recording mismatch, name and model the missing physics"


def configure(parser):
    """Arguments: those of ``bayescal fit`` (without its criticism options),
    with the same defaults: the base fit is the fit ``bayescal fit`` makes.
    With ``--ref-noise quiet`` the diagnosis's first step tests whether the
    reference's noise must be modelled
    (:mod:`bayescal.criticism.reference_noise`) and models it when it must."""
    add_pair_arguments(parser)


def run(args):
    """Run the diagnosis; returns the exit code."""
    from ..errors import InputError
    from ..io.result import write_json, write_results

    out = os.path.abspath(args.out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputError(f"{args.out}: exists and is not a folder")
    say = (lambda s: None) if args.quiet else (lambda s: print(s, file=sys.stderr))
    say("bayescal diagnose: base fit ...")
    with quiet_convergence_warnings():
        base, d = _run_diagnosis(args, say)
    # nothing modelled: the final fit is the base fit as bayescal fit reports it
    final = (base if d.final is base.state
             else d.final.replace(sut_inventory=base.sut_inventory).to_result())
    with staging(out) as tmp:
        write_results(final, tmp)
        # both fits as their result.json hold them (the base's self-noise included)
        write_json(os.path.join(tmp, "diagnosis.json"),
                   {**d.summary(), "base": base.summary(), "final": final.summary()})
        if not args.no_report:
            from ..report.diagnosis import write_page
            try:
                write_page(d, os.path.join(tmp, "diagnosis"), paper=args.paper)
            except Exception as exc:   # the findings matter more than the figure
                print(f"bayescal: warning: the diagnosis page could not be written "
                      f"({type(exc).__name__}: {exc})", file=sys.stderr)
    for s in d.sentences():
        print(s)
    short = (final.meta.record_length or {}).get("note")
    if short:
        print(f"record: {short}")
    code = convergence_exit([("the final model's sampler", final.summary()["convergence"])])
    say(f"wrote {out}")
    return code


def _run_diagnosis(args, say):
    """The base fit and its diagnosis: ``(base, Diagnosis)``."""
    from ..criticism.diagnose import diagnose
    from ..pair.workflow import calibrate_files

    base = calibrate_files(ref=args.ref, ref_xml=args.ref_xml, sut=args.sut,
                           sut_xml=args.sut_xml,
                           band=tuple(args.band) if args.band else None,
                           fit_response=args.fit_response, seed=args.seed,
                           start=args.start, end=args.end, progress=not args.quiet,
                           sut_id=args.sut_id, ref_id=args.ref_id,
                           ref_noise=args.ref_noise, ref_noise_psd=args.ref_noise_psd,
                           transients="keep" if args.keep_transients else "drop",
                           max_steps=args.max_steps, diagnose=False,
                           priors=priors_from(args))
    say("searching the catalogue of effects in rounds: each round scores every effect against "
        "the model so far and keeps the best one when it improves the fit by a BIC gain above 10 "
        "(very strong evidence) ...")
    return base, diagnose(base.state, seed=args.seed, progress=not args.quiet, log=say,
                          max_steps=args.max_steps)

