"""Dynamics of serial arms: inverse dynamics (recursive Newton-Euler), the mass, Coriolis and
gravity terms, friction, energies, forward dynamics and simulation, and a servo torque budget.

Batched over leading dimensions like :func:`labkit.kinematics.fk`; the robot's inertial
parameters come from its robot file (``mass``, ``com``, ``inertia``, ``motor`` per joint,
see ``docs/robot-files.md``). The Lagrangian derivation for small arms lives in
:mod:`labkit.dynamics.symbolic` (imports sympy when used).
"""

from labkit.dynamics import _budget, _rne, _simulate
from labkit.dynamics._model import STANDARD_GRAVITY
from labkit.dynamics._rne import (
    inverse_dynamics,
    mass_matrix,
    coriolis_matrix,
    gravity_torques,
    friction_torques,
    kinetic_energy,
    potential_energy,
)
from labkit.dynamics._simulate import forward_dynamics, Simulation, simulate, INTEGRATORS
from labkit.dynamics._budget import (
    TorqueBudget, torque_budget, stall_torques, torques_from_current, check_torque_budget,
)

__all__ = [
    "STANDARD_GRAVITY",
    *_rne.__all__,
    *_simulate.__all__,
    *_budget.__all__,
]
