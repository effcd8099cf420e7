"""One error family for the whole product.

Every message says what is wrong and what to do. The CLI and the nodes turn these into a one-line
reason and a non-zero exit code or ``success: false``; anything else escaping is a bug.
"""
from __future__ import annotations


class OrthoglideError(Exception):
    """Base of every error the product raises on purpose."""


class ConfigError(OrthoglideError):
    """A parameter, YAML file or command-line option is invalid."""


class ModelError(OrthoglideError):
    """The kinematic/dynamic model cannot be evaluated at the given state."""


class WorkspaceError(ModelError):
    """A joint position is outside the reachable workspace (no assembly exists)."""


class SingularityError(ModelError):
    """The robot is at (or too close to) a serial or parallel singularity."""


class BagError(OrthoglideError):
    """A bag is missing, unreadable, truncated beyond use, mis-tagged or lacks a topic."""


class DataError(OrthoglideError):
    """Recorded samples are unusable: NaN, mismatched joint names, too short, gaps."""


class ExcitationError(OrthoglideError):
    """The trajectories do not excite the parameters enough for a meaningful identification."""


class IdentificationError(OrthoglideError):
    """The identification problem is ill-posed with the data given (e.g. no loaded bag for TLS)."""


class SolverError(IdentificationError):
    """The physical-consistency solve found no answer (infeasible, not converged)."""
