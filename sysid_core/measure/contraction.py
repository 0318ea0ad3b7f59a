"""How fast the verified split falls, and whether a local design pays for itself at that rate.

Each answer of a model that is right up to its stiffness law's error leaves a split about a
fixed fraction ``r`` of the one it stepped from: a Newton step with a Jacobian off by ``r``
(``r`` the law's relative error where the run steps; a model that describes the gyro has
``r`` of 1 % or less, a law off by a third about 0.3). At the rate ``r`` seen in the last two
verified splits, verifying the next answers alone reaches the acceptance ``A`` from a split
``s`` after

``n = ceil(log(A / s) / log r)`` verifications,

each costing what the latest one cost on the bench clock. Measuring the local design first (the
experiments of eq. (18) around the bias that are not measured yet) costs its sweeps and at least
one verification after them. :func:`too_slow` says when the design is the cheaper way to the
acceptance (``n`` verifications cost more than the design and one verification), when the rate
would not reach it in the iterations the budget leaves, or when the split did not fall at all; the
run then measures the local design (:class:`~sysid_core.run.lean_protocol.LeanProtocol`, and a run
from a previous model, :class:`~sysid_core.measure.previous.PreviousModel`). Otherwise it fits
every sweep again and verifies the next answer: a model whose answers contract fast (``r`` of a few
percent) is not paid a design it does not need. The rate is read from the second verification on,
never from the split where the run started: the first answer carries the first design's law over
the whole first step (volts from the sweeps), while the next one comes from a model that holds a
sweep at the bias it steps from. That first rate overstates the next one's, so it may still decline
a design: a local run asking whether the sweeps it lacks pay before a second verified split reads
it (the split where the run started, then the verified one); where even that rate says verifying is
cheaper, the faster one says it too. On a drifting bench the rate is what the verified splits did,
the drift included: sweeps that the drift has made too old for the answers show as a split that
does not fall, and the design follows. (A rule that sent every tracked run to the local design once
its sweeps spanned an hour was measured and dropped: docs/studies/design-pays.md, "Sweeps an hour
old".)

The rate is a ratio of true splits, and a window measures its split with noise. Where the latest
window's 95 % interval reaches down to the acceptance, two splits give no rate: a split "risen"
from 0.93 to 1.13 mHz with intervals of 0-3.8 and 0.2-2.1 mHz may be the same split twice, and a
local design measures the law again where what is missing is a window that resolves the split
(the next verification, which the windows' forecast pools with the earlier ones). Told that
interval's lower end (``low_hz``), :func:`too_slow` then declines the design.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

__all__ = ["Costs", "design_or_not", "too_slow", "unresolved", "verifications_needed"]


@dataclass(frozen=True)
class Costs:
    """What the two ways forward cost on the bench clock (seconds, or acquisitions).

    Attributes
    ----------
    verify : float
        One verification (the latest one's sweeps).
    design : float
        The local design's sweeps not measured yet.
    """

    verify: float
    design: float

    @classmethod
    def of(
        cls, cost_s: Callable[[int, bool], float] | None, verify: Sequence[int], design: int
    ) -> Costs | None:
        """The costs of a verification and of a design of ``design`` sweeps like its first.

        ``cost_s(points, bias_change)``: what one sweep costs
        (:meth:`~sysid_core.clock.runclock.RunClock.sweep_s`); ``verify``: the points of each
        sweep of the latest verification (the first after a bias change). None without either.
        """
        if cost_s is None or not verify:
            return None
        once = sum(cost_s(n, k == 0) for k, n in enumerate(verify))
        return cls(once, design * cost_s(verify[0], True))


def verifications_needed(last_hz: float, split_hz: float, acceptance_hz: float) -> float:
    """Verifications that take ``split_hz`` under ``acceptance_hz`` at the rate ``split / last``.

    0 when it is already under; ``inf`` when the split did not fall.
    """
    if split_hz <= acceptance_hz:
        return 0.0
    rate = split_hz / last_hz
    if rate >= 1.0:
        return math.inf
    return float(math.ceil(math.log(acceptance_hz / split_hz) / math.log(rate) - 1e-9))


def unresolved(
    last_hz: float | None, split_hz: float, acceptance_hz: float, low_hz: float | None
) -> str | None:
    """One line for the progress when the latest split gives no rate, else None.

    The split is over the acceptance but the lower end of its window's 95 % interval
    (``low_hz``) is not (module docstring): the next verification, not a design, resolves it.
    The lean protocol says it where the rate, were it read, would have asked for the design.
    """
    if last_hz is None or low_hz is None or split_hz <= acceptance_hz or low_hz > acceptance_hz:
        return None
    return (
        f"the verified split went from {last_hz * 1e3:.3g} to {split_hz * 1e3:.3g} mHz, but its "
        f"window's 95 % interval reaches down to {low_hz * 1e3:.3g} mHz (acceptance "
        f"{acceptance_hz * 1e3:.3g} mHz): no rate to read, no local design; verifying the next "
        "answer"
    )


def too_slow(
    last_hz: float | None,
    split_hz: float,
    left: int,
    acceptance_hz: float,
    costs: Costs | None = None,
    low_hz: float | None = None,
) -> str | None:
    """Why verifying the next answers alone is the slower way to the acceptance, or None.

    Parameters
    ----------
    last_hz : float or None
        The split before the latest one (the run's start, or the previous verification); None:
        there is none.
    split_hz : float
        The latest verified split.
    left : int
        The iterations still to come (none: nothing to decide, None is returned).
    acceptance_hz : float
        The split the run must reach.
    costs : Costs, optional
        A verification's and the local design's bench time; without them, only the rate and
        the iterations left decide.
    low_hz : float, optional
        The lower end of the latest split's 95 % interval (its window's fit). At or under the
        acceptance the window does not tell its split from one that met it: the rate is the
        windows' noise, not the answers' (module docstring), and None is returned.

    Returns
    -------
    str or None
        One line for the progress: the split did not fall, the rate would not reach the
        acceptance in the iterations left, or the design and one verification cost less than
        the verifications the rate needs (module docstring).
    """
    if last_hz is None or left < 1 or last_hz <= 0 or split_hz <= acceptance_hz:
        return None
    if unresolved(last_hz, split_hz, acceptance_hz, low_hz) is not None:
        return None
    fell = f"the verified split fell from {last_hz * 1e3:.3g} to {split_hz * 1e3:.3g} mHz"
    needed = verifications_needed(last_hz, split_hz, acceptance_hz)
    if math.isinf(needed):
        return f"the verified split did not fall ({last_hz * 1e3:.3g} to {split_hz * 1e3:.3g} mHz)"
    if needed > left:
        at_end = split_hz * (split_hz / last_hz) ** left
        return (
            f"{fell}; at that rate it would be {at_end * 1e3:.3g} mHz after the {left} "
            "iteration(s) left"
        )
    if costs is not None and needed * costs.verify > costs.design + costs.verify:
        ratio = needed * costs.verify / (costs.design + costs.verify)
        return (
            f"{fell}; at that rate the {needed:.0f} verifications it needs would cost "
            f"{ratio:.2g} times the local design and one verification"
        )
    return None


def design_or_not(
    last_hz: float | None,
    split_hz: float,
    left: int,
    acceptance_hz: float,
    costs: Costs | None,
    low_hz: float | None,
) -> tuple[str | None, str | None]:
    """Why the local design is measured now (or None), and why not where the rate asked (or None).

    The first is :func:`too_slow`'s reason when the latest window resolves its split; the second
    the :func:`unresolved` line when the rate, were it read, would have asked for the design but
    the window does not resolve the split. At most one of the two is given.
    """
    why = too_slow(last_hz, split_hz, left, acceptance_hz, costs)  # the rate, were it read
    note = unresolved(last_hz, split_hz, acceptance_hz, low_hz) if why else None
    return (None, note) if note else (why, None)
