"""The error a fit raises when it cannot proceed."""


class FitError(RuntimeError):
    """The fit cannot proceed (nothing estimable, optimizer failure...)."""
