"""What an effect of the catalogue provides (:class:`CriticismEffect`).

An effect extends the pair likelihood (the hook,
:class:`bayescal.core.model.effect.Effect`: ``name``, ``param_names``,
``rows``, ``factor(freqs, p)`` equal to 1 at the null value, ``log_prior(p)``)
and, for the criticism, says what its parameters mean (``physical``) and
what it found in plain words (``explain``). The search
(:mod:`bayescal.criticism.search`) fits it as an extension of the current
model; the naming (:mod:`bayescal.criticism.naming`) reads ``null``,
``absence``, ``prunable`` and an ``identifiable`` method where there is
one; the diagnosis (:mod:`bayescal.criticism.diagnose`) reports
``physical``'s samples and ``explain``'s sentence.
"""
from __future__ import annotations

from ...core.model import Effect


class CriticismEffect(Effect):
    """An effect the criticism can name: the likelihood's extension
    (:class:`bayescal.core.model.effect.Effect`) with its parameters in
    physical units and its finding in words.

    A subclass sets ``name``, ``param_names`` and ``rows`` and implements
    ``factor``, ``log_prior``, :meth:`physical` and :meth:`explain`; it may
    set :attr:`multimodal`, :attr:`prunable`, :attr:`null`, :attr:`first` and
    :attr:`absence`, and give ``identifiable(p, fmin, fmax)`` (whether the
    parameters ``p`` are identifiable in the band, for an effect that can
    leave it) and ``prior_residual(p)`` (a proper prior's least-squares
    rows).
    """

    #: Least squares starts from several grid maxima (a likelihood with
    #: many maxima, as a delay's).
    multimodal = False
    #: The backward elimination may drop it (:func:`bayescal.criticism.naming.prune`).
    prunable = True
    #: The parameters' value with no effect.
    null = 0.0
    #: The search keeps it before the others whenever its gain passes
    #: (:func:`bayescal.criticism.search.search`): a term of the response
    #: family the metadata leave out altogether.
    first = False

    @property
    def absence(self):
        """Indices of the parameters whose null value is the effect's
        absence (all of them unless a subclass says otherwise)."""
        return tuple(range(self.n_params))

    def physical(self, p):
        """``{name: (W,) values}``: the parameters ``p`` (W, n_params) in
        physical units, as the summary reports them."""
        raise NotImplementedError

    def explain(self, med):
        """The finding in one sentence, from the medians of :meth:`physical`."""
        raise NotImplementedError
