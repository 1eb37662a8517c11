"""Recordings and metadata in, corrected metadata out.

* :mod:`.read`        waveforms and metadata (StationXML, RESP, GSE2 poles and zeros)
* :mod:`.validate`    checks of every metadata value a fit uses, as written and as read
* :mod:`.channels`    each sensor's channels chosen by SEED-id patterns
* :mod:`.align`       two or more sensors' recordings on one time grid
* :mod:`.band`        choice of the band where the sensors are coherent
* :mod:`.pipeline`    files or ObsPy objects -> spectra -> posterior
* :mod:`.noise`       files -> aligned sensors -> spectra -> self-noise estimates
                      of three or more co-located sensors, noise.json
* :mod:`.refnoise_file` the reference's self-noise given in a file
* :mod:`.result`      a fit's result.json / samples.npz written and read back
* :mod:`.stationxml`  the SUT's StationXML with the posterior's values

May import :mod:`bayescal.core` and :mod:`bayescal.criticism` (the pipeline criticises a
fit that fails its model check); never coil, report, network or cli.
"""
from .align import align, align_sensors
from .read import (CODE_ORIENTATION, flat_inventory, metadata_format,
                   orientation_from_code, paz_inventory, read_gse2_paz, read_metadata,
                   read_waveforms, two_pole_inventory)

__all__ = ["CODE_ORIENTATION", "align", "align_sensors",
           "flat_inventory", "metadata_format", "orientation_from_code", "paz_inventory",
           "read_gse2_paz", "read_metadata", "read_waveforms", "two_pole_inventory"]
