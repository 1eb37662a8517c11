"""A sensor's metadata as a fit takes them: an ObsPy Inventory, a metadata
file or the word ``flat``, and which of its channels are bayescal
placeholders."""
from __future__ import annotations

from .read import InputError, flat_inventory, read_metadata


def load_inventory(spec, stream, side="StationXML"):
    """An Inventory from ``spec``: an ObsPy Inventory, a metadata file
    (StationXML, RESP, or GSE2 poles and zeros applied to every channel of
    ``stream``; see :func:`bayescal.io.read_metadata`), or
    the word ``"flat"`` (flat velocity response, orientations from the
    channel codes: N/1 north, E/2 east, Z/3 vertical; see
    :func:`bayescal.io.flat_inventory`)."""
    if spec is None:
        raise InputError(f"no {side} given")
    if hasattr(spec, "networks"):
        return spec
    if str(spec).lower() == "flat":
        return flat_inventory(stream)
    return read_metadata(spec, side, stream=stream)


def placeholder_channels(inventory, ids):
    """The ids among ``ids`` whose metadata are bayescal placeholders
    (``flat``: their deconvolved spectra are counts, not ground units)."""
    out = []
    for cid in ids:
        net, sta, loc, cha = str(cid).split(".")
        chans = [c for n in inventory.select(network=net, station=sta, location=loc, channel=cha)
                 for s in n for c in s]
        if any(getattr(c, "subject", None) == "bayescal placeholder"
               for ch in chans for c in ch.comments):
            out.append(str(cid))
    return out


def assumed_flat(inventory):
    """True when ``inventory`` is the invented flat response of ``flat``."""
    return any("assumed flat" in (c.value or "") for net in inventory for sta in net
               for ch in sta for c in ch.comments)
