"""A fit's result as saved and read back: the frozen :class:`.record.Result`,
its :class:`.meta.Meta` and :class:`.convergence.Convergence`, and the one
schema that writes them to a folder and reads them from it.

* :mod:`.record`      :class:`~bayescal.result.record.Result`: samples, their
                      summaries and what was run
* :mod:`.labels`      what each sampled parameter is, in words, and the short
                      text ``print(result)`` shows
* :mod:`.meta`        :class:`~bayescal.result.meta.Meta`: what was run, by name
* :mod:`.convergence` :class:`~bayescal.result.convergence.Convergence`: a
                      chain's convergence figures and their summary
* :mod:`.schema`      ``result.json``, ``samples.npz``, ``diagnostics.npz``:
                      written and read (schema ``bayescal.fit/1``)

Light on purpose: its modules import only numpy and the standard library,
so reading a result loads no model, sampler, plotting or ObsPy module.
Imports no other part of bayescal but the leaves :mod:`bayescal.atomic` (to
write) and :mod:`bayescal.errors` (to refuse a file of another schema).
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "record": ["SCHEMA", "Posterior", "Result", "jsonable"],
    "meta": ["Meta", "by_channel"],
    "convergence": ["Convergence"],
    "schema": ["load", "load_posterior", "save", "write_json"],
})
