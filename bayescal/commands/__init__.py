"""One module per ``bayescal`` sub-command (see :mod:`bayescal.cli`)."""
