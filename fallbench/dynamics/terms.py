"""Rigid-body terms at one measured state, computed once per control step and shared by the QP's
tasks, limits and the acceleration map (Pinocchio coordinates, Pinocchio's velocity convention)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics import kernels
from fallbench.dynamics.contacts import ContactSet
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.state import RobotState


@dataclass
class ModelTerms:
    state: RobotState  # the kinematics: what tasks and limits take
    H: np.ndarray | None  # inertia matrix (with rotor armature), (nv, nv); None unless asked for
    H_inv: np.ndarray | None  # the inverse inertia matrix; None unless asked for
    C: np.ndarray  # gravity, Coriolis and centrifugal terms, N or Nm


def model_terms(
    robot: PinocchioModel,
    q: np.ndarray,
    v: np.ndarray,
    points: ContactSet,
    inertia: bool = False,
    inverse: bool = True,
) -> ModelTerms:
    """All terms at (q, v) with the contact points `points`, the inertia matrix itself only if
    `inertia`, its inverse only if `inverse`; the kinematic pass last, so that the state's data
    holds it."""
    model, data = robot.model, robot.data
    H = kernels.symmetric(pin.crba(model, data, q)) if inertia else None
    H_inv = kernels.symmetric(pin.computeMinverse(model, data, q)) if inverse else None
    C = pin.nonLinearEffects(model, data, q, v).copy()
    return ModelTerms(RobotState.measure(robot, q, v, points), H, H_inv, C)
