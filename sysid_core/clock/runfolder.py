"""The output folder of a tuning run: created, locked, resumed, and what is written where.

* A new run needs an absent or empty folder. ``--resume`` needs a folder that holds a run of the
  same configuration (its ``config.json``); a folder with other files is never written into.
* While a process works in the folder it holds an exclusive lock on ``.sysid.lock`` (an OS
  file lock, released when the process ends, however it ends); a second process is refused.
* :meth:`RunFolder.read_or_measure`: every measurement is saved before it is used; on resume
  it is read back instead of measured again. A device answer that is not a valid measurement
  is kept in ``rejected/`` with the reason, never as a measurement, so a resumed run measures
  it again.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np
import xarray as xr

from sysid_core.data.io import atomic_write, write_json
from sysid_core.data.schema import load_dataset, requested_bias, save_dataset
from sysid_core.errors import InvalidAnswerError, RunFolderError, RunLockedError

__all__ = ["RunFolder"]

LOCK_NAME = ".sysid.lock"
CONFIG_NAME = "config.json"


def _lock(handle: IO[str]) -> bool:
    """Take an exclusive, non-blocking lock on ``handle``; False if another process holds it."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        import msvcrt

        try:
            # typeshed defines msvcrt's functions only for Windows, the one place this runs
            msvcrt.locking(handle.fileno(), msvcrt.LK_NBLCK, 1)  # type: ignore[attr-defined]
        except OSError:
            return False
        return True
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


class RunFolder:
    """One run's output folder.

    Parameters
    ----------
    path : path
        The folder.
    digest : str
        The configuration's digest (:meth:`PipelineConfig.digest`), stored in ``config.json``
        and compared on resume.
    """

    def __init__(self, path: str | os.PathLike[str], digest: str) -> None:
        self.path = Path(path)
        self.digest = digest
        self._handle: IO[str] | None = None

    # ------------------------------------------------------------------ checks
    def check(self, resume: bool) -> None:
        """Check, without writing anything, that the run may use this folder.

        Raises
        ------
        RunFolderError
            If the folder holds another run, files that are no run, or (``resume``) no run.
        """
        p = self.path
        if p.exists() and not p.is_dir():
            raise RunFolderError(f"--out {p} is a file, not a folder; choose another --out")
        has_files = p.exists() and any(x.name != LOCK_NAME for x in p.iterdir())
        cfg = p / CONFIG_NAME
        if not resume:
            if has_files and cfg.exists():
                raise RunFolderError(
                    f"{p} already holds a run; pass --resume to continue it, or choose another "
                    "--out"
                )
            if has_files:
                raise RunFolderError(
                    f"{p} is not empty and holds no sysid run; choose another --out (nothing "
                    "is written into a folder of other files)"
                )
            return
        if not cfg.exists():
            if has_files:
                raise RunFolderError(
                    f"cannot resume: {p} holds files but no sysid run (no {CONFIG_NAME}); give "
                    "the folder of the run to continue"
                )
            raise RunFolderError(
                f"cannot resume: {p} holds no run; run without --resume to start a new one"
            )
        try:
            old = json.loads(cfg.read_text()).get("digest")
        except (OSError, ValueError, AttributeError):
            raise RunFolderError(f"cannot resume: {cfg} is not a sysid run's config.json") from None
        if old != self.digest:
            raise RunFolderError(
                f"{p} holds a run with a different configuration; resume it with the same "
                "configuration file or choose another --out"
            )

    # ------------------------------------------------------------------ lock
    def acquire(self, resume: bool, config: dict[str, Any]) -> None:
        """Check the folder, create it, lock it and write ``config.json``.

        Raises
        ------
        RunLockedError
            If another process is working in the folder.
        """
        self.check(resume)
        self.path.mkdir(parents=True, exist_ok=True)
        handle = open(self.path / LOCK_NAME, "a+")  # held (locked) for the run's life
        if not _lock(handle):
            handle.close()
            raise RunLockedError(
                f"another sysid process is working in {self.path} (it holds {LOCK_NAME}); wait "
                "for it to finish or stop it, then resume"
            )
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        self._handle = handle
        self.check(resume)  # again, now that nobody else can change it
        write_json(self.path / CONFIG_NAME, {"digest": self.digest, "config": config})

    def release(self) -> None:
        """Release the lock (the lock file stays; it is harmless)."""
        if self._handle is not None:
            self._handle.close()
            self._handle = None

    def __enter__(self) -> RunFolder:
        """The folder itself; its lock is released on leaving the ``with`` block."""
        return self

    def __exit__(self, *exc: object) -> None:
        """Release the lock (:meth:`release`)."""
        self.release()

    # ------------------------------------------------------------------ measurements
    def read_or_measure(
        self,
        path: Path,
        bias: np.ndarray,
        freqs: np.ndarray,
        measure: Callable[[], xr.Dataset],
    ) -> tuple[xr.Dataset, bool]:
        """The measurement at ``path``: read back (resume) or ``measure()``-d and saved first.

        Returns the one-experiment data set and whether it was read. A file at ``path`` at
        another bias or grid is an error, never silently used. An answer that
        :func:`~sysid_core.device.measuring.check_answer` rejected is kept aside (:meth:`reject`).

        Raises
        ------
        RunFolderError
            If ``path`` holds another measurement than this one.
        InvalidAnswerError
            If the device's answer is not a valid measurement (it is kept in ``rejected/``).
        """
        if path.exists():
            ds = load_dataset(path)
            same_grid = ds.sizes["frequency"] == freqs.size and np.allclose(
                ds["frequency"].values, freqs, rtol=0, atol=1e-9
            )
            if same_grid and np.allclose(requested_bias(ds), bias, rtol=0, atol=1e-12):
                return ds, True
            raise RunFolderError(
                f"{path} holds a measurement at another bias or frequency grid than this run "
                "needs now; the run cannot be resumed (start a new one in another --out)"
            )
        try:
            ds = measure()
        except InvalidAnswerError as exc:
            kept = self.reject(
                f"{path.parent.name}-{path.stem}", getattr(exc, "answer", None), str(exc)
            )
            raise InvalidAnswerError(
                f"{exc}; the answer is kept in {kept.parent} (not as a measurement), --resume "
                "measures it again"
            ) from None
        save_dataset(ds, path)  # saved before it is processed
        return ds, False

    # ------------------------------------------------------------------ rejected answers
    def reject(self, name: str, answer: object, reason: str) -> Path:
        """Keep a rejected device answer in ``rejected/`` with its reason; return its path."""
        folder = self.path / "rejected"
        folder.mkdir(exist_ok=True)
        n = 1 + sum(1 for x in folder.glob(f"{name}-*.txt"))
        stem = f"{name}-{n}"
        note = f"{reason}\n"
        if isinstance(answer, xr.DataArray):
            try:
                values = np.asarray(answer.values)
                ds = xr.Dataset(
                    {
                        "answer_real": (answer.dims, np.real(values)),
                        "answer_imag": (answer.dims, np.imag(values)),
                    },
                    coords={k: v for k, v in answer.coords.items() if k in answer.dims},
                )
                atomic_write(
                    folder / f"{stem}.nc", lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf")
                )
            except Exception as exc:  # keep at least the text
                note += f"(the answer could not be saved as netCDF: {exc})\n{answer!r}\n"
        else:
            note += f"{answer!r}\n"
        return atomic_write(folder / f"{stem}.txt", lambda tmp: tmp.write_text(note))
