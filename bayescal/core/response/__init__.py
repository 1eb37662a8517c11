"""Instrument responses.

* :mod:`.family`   the parametric two-pole family (period, damping, gain) of a
                   velocity sensor, and the evaluation of ObsPy responses
* :mod:`.evalresp` a numpy evaluation of an ObsPy ``Response``
* :mod:`.paz`      a poles-and-zeros transfer function and its normalisation
* :mod:`.pendulum` the pendulum pair in the coordinates the data see, its
                   prior, and what the data fix
* :mod:`.reference_tolerance` the reference's metadata tolerance carried into
                   the SUT's response samples

Imports no other part of :mod:`bayescal.core`.
"""
