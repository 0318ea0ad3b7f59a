"""How fast the verified split falls, and whether it reaches the acceptance in time at that rate.

A model that describes the gyro brings the split down by orders of magnitude per iteration
(the cloverleaf: 2-170 mHz after the first answer, under 1 mHz after the second). A model whose
bias law holds only roughly (a law off by a third, a law fitted far from the answer) brings it
down by a constant factor, 3-10 per iteration, while each new verification, fitted with the
rest, still agrees with it: a gyro with input dynamics in a good lab went 2643, 249, 43 and
19 mHz in four iterations, where the local design measured after the third reached 0.7 mHz.
:func:`too_slow` says when the rate seen in the last two verifications would leave the split
over the acceptance after the iterations left; the run then measures the local design
(:class:`~sysid_core.run.protocols.LeanProtocol`, and a run from a previous model,
:class:`~sysid_core.measure.previous.PreviousModel`).
"""

from __future__ import annotations

__all__ = ["too_slow"]


def too_slow(last_hz: float | None, split_hz: float, left: int, acceptance_hz: float) -> str | None:
    """Why the split falls too slowly to reach the acceptance, or None.

    Parameters
    ----------
    last_hz : float or None
        The verified split before the latest one (None: there is none).
    split_hz : float
        The latest verified split.
    left : int
        The iterations still to come (none: nothing to decide, None is returned).
    acceptance_hz : float
        The split the run must reach.

    Returns
    -------
    str or None
        One line for the progress, when ``split · (split / last)^left`` exceeds the acceptance.
    """
    if last_hz is None or left < 1 or last_hz <= 0 or split_hz <= acceptance_hz:
        return None
    at_end = split_hz * (split_hz / last_hz) ** left
    if at_end <= acceptance_hz:
        return None
    return (
        f"the verified split fell from {last_hz * 1e3:.3g} to {split_hz * 1e3:.3g} mHz; at that "
        f"rate it would be {at_end * 1e3:.3g} mHz after the {left} iteration(s) left"
    )
