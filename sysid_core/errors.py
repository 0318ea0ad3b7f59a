"""The toolkit's exception hierarchy.

Every error the toolkit raises on purpose is a :class:`SysidError`. Each also subclasses the
builtin exception a caller would naturally catch (``ValueError`` for bad input, ``LookupError`` for
unknown names, ``RuntimeError`` for failed computations), so code that does not know this module
still works. Messages say what was wrong and how to fix it; the command-line program prints them
as one line.
"""

from __future__ import annotations

__all__ = [
    "BiasLimitError",
    "BudgetSpentError",
    "ConfigError",
    "DataError",
    "DeviceError",
    "DimensionError",
    "FileFormatError",
    "FitError",
    "FitWarning",
    "FrequencyGridError",
    "InvalidAnswerError",
    "ManifestError",
    "MissingBiasError",
    "ModelError",
    "NonFiniteDataError",
    "NotConvergedError",
    "OutputError",
    "PluginError",
    "PluginNotFoundError",
    "RankConditionError",
    "RunFolderError",
    "RunLockedError",
    "RunsFailedError",
    "SolverError",
    "SysidError",
    "SysidWarning",
    "TooFewExperimentsError",
    "UnreachableTuningError",
]


class SysidError(Exception):
    """Base class of every error raised on purpose by sysid-toolkit."""


class ConfigError(SysidError, ValueError):
    """A configuration file or option is invalid (unknown key, wrong type, bad value)."""


class DataError(SysidError, ValueError):
    """A frequency-response data set is not usable."""


class NonFiniteDataError(DataError):
    """The data contain NaN or infinite values where a measurement is expected."""


class DimensionError(DataError):
    """Wrong dimensions, shapes or coordinates."""


class FrequencyGridError(DataError):
    """Frequencies are not strictly increasing, are duplicated, or are not positive."""


class MissingBiasError(DataError):
    """The bias potentials of some experiment or electrode are missing."""


class TooFewExperimentsError(DataError):
    """Fewer than ``n_e + 1`` experiments: the stiffness matrices cannot be identified."""


class RankConditionError(DataError):
    """The experiment design violates the rank condition (6) of Kim & M'Closkey (2006)."""


class FileFormatError(DataError):
    """A response file cannot be read: missing, of an unknown kind, or not in its format.

    The message names the file and the line (CSV, Touchstone) or variable (.mat, netCDF).
    """


class ManifestError(DataError):
    """A manifest of measured experiments is invalid: unknown key, wrong type, missing file.

    The message names the manifest and, where it applies, the experiment's index.
    """


class PluginError(SysidError):
    """A plugin is broken or inconsistent."""


class PluginNotFoundError(PluginError, LookupError):
    """A component name was asked for that no installed plugin provides."""


class SolverError(SysidError, RuntimeError):
    """A conic solver failed or returned an inaccurate answer.

    Attributes
    ----------
    status : sysid_core.conic.program.SolveStatus or None
        How the solve ended, in the toolkit's words.
    word : str or None
        The solver's own status word (for messages only).
    x : ndarray or None
        The solver's last iterate when it ended inaccurate (``AlmostSolved``): for callers that
        check an answer independently (the tuning criteria recompute the split from the model),
        never for a fit.
    """

    def __init__(
        self, message: str, status: object = None, word: str | None = None, x: object = None
    ) -> None:
        super().__init__(message)
        self.status = status
        self.word = word
        self.x = x


class FitError(SysidError, RuntimeError):
    """The model fit could not be completed."""


class DeviceError(SysidError, RuntimeError):
    """A device failed while measuring (an exception, a timeout, bad output)."""


class BiasLimitError(SysidError, ValueError):
    """A bias outside the device's limits was about to be applied. It never is."""


class BudgetSpentError(SysidError, RuntimeError):
    """The run's bench-time budget (``[tuning] max_bench_minutes``) is spent.

    Raised before a measurement that would end past it; a run that has verified an answer
    ends with it instead (:mod:`sysid_core.clock.budget`).
    """


class UnreachableTuningError(SysidError, RuntimeError):
    """The tuning goal cannot be reached inside the device's bias limits.

    Attributes
    ----------
    best_bias : list of float or None
        The bias (volts) achieving the best reachable value.
    best_value : float or None
        The best reachable split or frequency error (Hz).
    """

    def __init__(
        self, message: str, best_bias: list[float] | None = None, best_value: float | None = None
    ) -> None:
        super().__init__(message)
        self.best_bias = best_bias
        self.best_value = best_value


class ModelError(SysidError, ValueError):
    """A fitted model was asked for something outside its domain.

    For example a non-finite bias, or a bias at which the model's stiffness is not positive
    definite (no oscillating modes there).
    """


class RunLockedError(SysidError, RuntimeError):
    """Another process is working in the same run folder."""


class RunsFailedError(SysidError, RuntimeError):
    """Some runs of a batch (a study, a fleet) failed; the others' results were kept."""


class SysidWarning(UserWarning):
    """Base class of every warning issued by sysid-toolkit."""


class FitWarning(SysidWarning):
    """A fit completed but its result is probably meaningless.

    Issued for data that are constant or show no resonance, and for fitted modes outside the
    data's frequency span.
    """


class OutputError(SysidError, ValueError):
    """An output path must not be written.

    It is an input file, a link, a non-regular file, or an existing file without ``--force``.
    """


class RunFolderError(SysidError, ValueError):
    """An output folder cannot hold this run (it holds another run, or files that are no run)."""


class InvalidAnswerError(DeviceError):
    """A device answered with something that is not a valid measurement.

    The answer is kept aside for inspection, never used as a measurement.
    """


class NotConvergedError(SysidError, RuntimeError):
    """A tuning run ended without meeting its goals (every result is still saved).

    Attributes
    ----------
    summary : object
        The run's summary (:class:`sysid_core.run.pipeline.RunSummary`).
    """

    def __init__(self, message: str, summary: object = None) -> None:
        super().__init__(message)
        self.summary = summary
