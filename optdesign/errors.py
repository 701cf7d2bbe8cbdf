"""The exceptions optdesign raises: one small hierarchy, messages that name file, key and fix."""


class OptDesignError(Exception):
    """Base class of every error optdesign raises on purpose."""


class ProblemError(OptDesignError, ValueError):
    """A problem file (or a design given in code) is not valid; the CLI exits with code 2."""


class UsageError(OptDesignError, ValueError):
    """A command-line argument or an output folder that cannot work (exit 2), found before
    any work is done: one line naming the option and what is wrong."""


class AssemblyError(OptDesignError):
    """A design does not assemble: names the chain and the crank angle where it fails (exit 1)."""

    def __init__(self, chain: int, phi_deg: float, detail: str = ""):
        self.chain = chain
        self.phi_deg = phi_deg
        self.detail = detail
        text = f"chain {chain} does not assemble at crank angle {phi_deg:.2f} deg"
        super().__init__(text + (f" ({detail})" if detail else ""))

    def __reduce__(self):
        """Pickled with its own arguments: a polish's outcome crosses a process boundary
        with the failure it verified (the default would call ``__init__`` with the message
        alone, and the pool's reader would die unpickling it)."""
        return type(self), (self.chain, self.phi_deg, self.detail)


class SolveError(OptDesignError):
    """The optimiser could not produce a result at all (not raised for a mere failed solve)."""


class UnitWarning(UserWarning):
    """A problem file's value is valid but likely in another unit (a length in metres, an
    angle in radians, a speed in rpm): the command goes on, with one line on stderr."""


#: longest repr of a user's value that a message quotes
SHOWN_CHARS = 60


def shown(value, limit: int = SHOWN_CHARS) -> str:
    """A bounded repr of ``value`` for a one-line message: a value read from a file may be a
    megabyte of text or a list of lists a thousand deep, and the message must stay short."""
    import reprlib

    r = reprlib.Repr()
    r.maxlevel, r.maxstring, r.maxother, r.maxlong = 3, limit, limit, limit
    r.maxlist = r.maxtuple = r.maxdict = r.maxset = r.maxfrozenset = 6
    try:
        text = r.repr(value)
    except (ValueError, RecursionError):   # an int past str()'s digit limit, a deep custom type
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[:limit - 3] + "..."
