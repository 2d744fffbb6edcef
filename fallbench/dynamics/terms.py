"""Rigid-body terms at one measured state, computed once per control step and shared by the QP's
tasks, limits and the acceleration map (Pinocchio coordinates, Pinocchio's velocity convention)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics import kernels
from fallbench.dynamics.contacts import ContactKinematics, ContactSet, contact_kinematics
from fallbench.dynamics.model import PinocchioModel


@dataclass
class ModelTerms:
    q: np.ndarray
    v: np.ndarray
    H: np.ndarray | None  # inertia matrix (with rotor armature), (nv, nv); None unless asked for
    H_inv: np.ndarray | None  # the inverse inertia matrix; None unless asked for
    C: np.ndarray  # gravity, Coriolis and centrifugal terms, N or Nm
    contacts: ContactKinematics
    com: np.ndarray  # m
    vcom: np.ndarray  # m/s
    com_drift: np.ndarray  # m/s^2, J_com_dot v
    J_com: np.ndarray  # (3, nv)


def model_terms(
    P: PinocchioModel,
    q: np.ndarray,
    v: np.ndarray,
    points: ContactSet,
    inertia: bool = False,
    inverse: bool = True,
) -> ModelTerms:
    """All terms at (q, v), the inertia matrix itself only if `inertia`, its inverse only if `inverse`; afterwards P.data holds the
    kinematics every task's `compute` needs (forwardKinematics(q, v, 0), computeJointJacobians(q),
    updateFramePlacements)."""
    model, data = P.model, P.data
    H = kernels.symmetric(pin.crba(model, data, q)) if inertia else None
    H_inv = kernels.symmetric(pin.computeMinverse(model, data, q)) if inverse else None
    C = pin.nonLinearEffects(model, data, q, v).copy()
    # one kinematic pass; the Jacobians and the CoM terms then read it (same bits as from q again)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.computeJointJacobians(model, data)
    pin.updateFramePlacements(model, data)
    contacts = contact_kinematics(P, v, points)
    pin.centerOfMass(model, data, pin.KinematicLevel.ACCELERATION, True)
    com, vcom, com_drift = data.com[0].copy(), data.vcom[0].copy(), data.acom[0].copy()
    J_com = pin.jacobianCenterOfMass(model, data, False).copy()  # subtree CoMs from centerOfMass
    return ModelTerms(q, v, H, H_inv, C, contacts, com, vcom, com_drift, J_com)
