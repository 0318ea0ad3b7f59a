"""Built-in fit objectives: ``minimax`` (the paper's eq. 8/10) and ``least-squares``."""

from sysid_objectives.least_squares import LeastSquares
from sysid_objectives.minimax import Minimax

__all__ = ["LeastSquares", "Minimax"]
