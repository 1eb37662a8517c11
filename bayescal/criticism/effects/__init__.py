"""The catalogue of physics that the base calibration model leaves out:
one effect per module, each a :class:`.base.CriticismEffect` (a factor on
the SUT deconvolution that equals 1 at the effect's null value, so the
extended model nests the base model, with its parameters in physical units
and a sentence in plain words), and the screens that score how well the
misfit located after the base fit looks like each.

* :mod:`.base`       the interface an effect provides
* :mod:`.timing`     a timing offset between the digitizers (:class:`TimingOffset`)
* :mod:`.drift`      a drifting SUT clock (:class:`ClockDrift`, and
                     :class:`CorrectedDrift` once its rate is taken out of the
                     spectra), with its screen :func:`drift_signature`
* :mod:`.pole`       a pole missing from the SUT's or the reference's metadata
                     (:class:`ExtraPole`)
* :mod:`.gain`       a sensitivity off its metadata value (:class:`GainError`)
* :mod:`.response_parameters`  the SUT's period and damping off their metadata
                     values (:class:`ResponseParameters`)
* :mod:`.corner`     the SUT's low-frequency corner off its metadata, or where
                     its metadata give none, with a wide prior (:class:`SutCorner`)
* :mod:`.screens`    the screens of the response-side candidates from the
                     per-band ratio (timing offset, extra pole, gain error)
* :mod:`.tilt_ratio` the coherence-ratio rule for tilt noise, the baseline of
                     :mod:`bayescal.criticism.tilt`
* :mod:`.catalogue`  the effects by name (:data:`.catalogue.CATALOGUE`)

Reversed and exchanged channels are screened from the fitted axes
(:mod:`bayescal.criticism.wiring`) and tilt noise is a nested extension of a
noise-spectrum model (:mod:`bayescal.criticism.tilt`): neither changes the
response, so neither is an effect here. A new effect is a module here with
a :class:`.base.CriticismEffect`, listed in :data:`.catalogue.CATALOGUE`, and its
candidates (where the search tries it, with its starting grid) in
:mod:`bayescal.criticism.search`.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "base": ["CriticismEffect"],
    "catalogue": ["CATALOGUE"],
    "corner": ["SutCorner"],
    "drift": ["ClockDrift", "CorrectedDrift", "drift_corrected", "drift_signature"],
    "gain": ["GainError"],
    "pole": ["IDENTIFIABLE_RATIO", "ExtraPole"],
    "response_parameters": ["ResponseParameters", "measured"],
    "screens": ["signatures"],
    "tilt_ratio": ["TILT_RATIO", "tilt_signature"],
    "timing": ["TimingOffset"],
})
