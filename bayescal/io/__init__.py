"""Recordings and metadata in, corrected metadata out.

* :mod:`.read`        waveforms and metadata (StationXML, RESP, GSE2 poles and zeros)
* :mod:`.validate`    checks of every metadata value a fit uses, as written and as read
* :mod:`.channels`    each sensor's channels chosen by SEED-id patterns
* :mod:`.align`       two or more sensors' recordings on one time grid
* :mod:`.band`        choice of the band where the sensors are coherent
* :mod:`.inventory`   a sensor's metadata as a fit takes them, placeholders
* :mod:`.noise`       files -> aligned sensors -> spectra -> self-noise estimates
                      of three or more co-located sensors, noise.json
* :mod:`.refnoise_file` the reference's self-noise given in a file
* :mod:`.result`      a fit's result.json / samples.npz written and read back,
                      with the corrected StationXML beside them
* :mod:`.stationxml`  the SUT's StationXML with the posterior's values
* :mod:`.relative_response` the headline model's response effects written
                      into it: the SUT's response relative to the reference's metadata

May import :mod:`bayescal.core` and :mod:`bayescal.result`; never criticism,
pair, coil, report, network or cli.

Its public names (``__all__``) are loaded on first use
(:func:`lazy_loader.attach`): importing this package costs no import time.
"""
import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(__name__, submod_attrs={
    "read": ["CODE_ORIENTATION", "channel_meta", "flat_inventory", "metadata_format",
             "orientation_from_code", "paz_inventory", "read_gse2_paz", "read_metadata",
             "read_waveforms", "two_pole_inventory"],
    "align": ["align_sensors"],
    "band": ["MIN_COHERENCE", "choose_band"],
    "inventory": ["assumed_flat", "load_inventory", "placeholder_channels"],
    "result": ["load_posterior", "save_posterior", "write_corrected_result", "write_results"],
    "noise": ["AXIS_MISMATCH", "self_noise_files", "self_noise_streams", "to_json"],
    "refnoise_file": ["for_channels", "read_reference_noise"],
    "stationxml": ["corrected_inventory", "find_channel", "pole_with_errors", "prior_text",
                   "update_response", "write_corrected", "write_pendulum"],
    "relative_response": ["change", "effect_changes"],
})
