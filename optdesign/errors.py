"""The exceptions optdesign raises: one small hierarchy, messages that name file, key and fix."""


class OptDesignError(Exception):
    """Base class of every error optdesign raises on purpose."""


class ProblemError(OptDesignError, ValueError):
    """A problem file (or a design given in code) is not valid; the CLI exits with code 2."""


class AssemblyError(OptDesignError):
    """A design does not assemble: names the chain and the crank angle where it fails (exit 1)."""

    def __init__(self, chain: int, phi_deg: float, detail: str = ""):
        self.chain = chain
        self.phi_deg = phi_deg
        text = f"chain {chain} does not assemble at crank angle {phi_deg:.2f} deg"
        super().__init__(text + (f" ({detail})" if detail else ""))


class SolveError(OptDesignError):
    """The optimiser could not produce a result at all (not raised for a mere failed solve)."""
