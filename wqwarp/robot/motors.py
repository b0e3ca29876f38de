"""The wheeled Go1's motors as the battery sees them: per actuator type, the electrical power of one joint from its
output torque tau [N m] and speed qd [rad/s] (issue 48; beyond the paper, whose cost is mechanical).

Model (per joint, quasi-static, no inductance)::

    tau_m = tau / G                         motor-side torque [N m], G the gear ratio (output / motor)
    p_copper = (tau_m / k_m)^2              winding (I^2 R) loss [W], k_m = k_t / sqrt(R) [N m / sqrt(W)]
    p_friction = (c + b |qd|) |qd|          optional gearbox / bearing loss [W], output side (c [N m], b [N m s / rad])
    p = tau qd + p_copper + p_friction      electrical power drawn from the bus [W]; negative = generating
    p_battery = p if p >= 0 else regen * p  regen in [0, 1]: the share of generated power the battery takes back

The motor constant k_m is used instead of k_t and R apart because it is free of the phase-current convention that
makes datasheet k_t values disagree (peak vs RMS, phase vs line resistance): k_m^2 = tau_m^2 / p_copper whatever
the convention. The joint friction that the physics already simulates (the asset's frictionloss and damping) is
inside tau qd; ``p_friction`` is for losses the physics does not have. A constant electronics draw (computers,
drivers at idle) is reported apart, not per joint (:attr:`MotorModel.electronics_w`).

Sources (each value with its range; the sensitivity of the results to them is issue 48's to measure):
    AK80-6 (the wheels): gear 6, k_m = 0.2206 N m / sqrt(W) motor side (k_t 0.091 N m / A over the 170 mOhm
    line-to-line resistance; T-Motor data as tabulated by the DFKI double_pendulum project,
    ``docs/hardware.motors.tmotors``). Measured q-axis k_t of the same 80-size KV100 motor is up to 26 % higher
    (0.115 on the AK80-9, neurobionics/TMotorCANControl ``mit_can.py``): k_m 0.22-0.28.
    Go1 leg motors: gear 6.33 (hip, thigh; the GO-M8010-6 as third-party drivers give it; mjlab's Go1 uses 6) and
    1.5x that at the knee (the URDF's knee torque and speed limits are 1.5x the hip's: 35.55 / 23.7, 30.1 / 20.06).
    No public k_t or winding resistance of the Go1's motor was found; the stand-in is the MIT Mini Cheetah motor of
    the same class (Cheetah-Software ``MiniCheetah.h``: k_t 0.05 x 1.5 = 0.075 N m per q-axis A, R 0.173 Ohm
    per phase, copper loss 1.5 R i_q^2): k_m = 0.075 / sqrt(1.5 x 0.173) = 0.147 N m / sqrt(W); with Ben Katz's
    AK80 firmware R 0.13 Ohm it is 0.170, and the AK80-6 (a motor of the same size) is 0.22: range 0.147-0.22.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from wqwarp.robot.constants import NUM_ACTUATED, NUM_LEG_JOINTS


@dataclass(frozen=True)
class ActuatorType:
    """One kind of actuator: its gearbox, its motor constant and its optional friction loss."""

    name: str
    gear_ratio: float
    """Output turns per motor turn, inverted: motor speed = gear_ratio x joint speed [-]."""
    motor_constant: float
    """k_m = k_t / sqrt(R), motor side [N m / sqrt(W)]: copper loss = (motor torque / k_m)^2."""
    motor_constant_range: tuple[float, float]
    """The range of k_m the public sources allow (the sensitivity study sweeps it) [N m / sqrt(W)]."""
    coulomb_friction: float = 0.0
    """Output-side Coulomb friction torque whose loss the physics does not simulate [N m] (0: none)."""
    viscous_friction: float = 0.0
    """Output-side viscous friction coefficient whose loss the physics does not simulate [N m s / rad] (0: none)."""

    def __post_init__(self) -> None:
        lo, hi = self.motor_constant_range
        if not (self.gear_ratio > 0 and self.motor_constant > 0 and 0 < lo <= self.motor_constant <= hi):
            raise ValueError(f"{self.name}: need gear_ratio > 0 and 0 < range[0] <= motor_constant <= range[1]")
        if self.coulomb_friction < 0 or self.viscous_friction < 0:
            raise ValueError(f"{self.name}: friction coefficients must be >= 0")

    @property
    def copper_coefficient(self) -> float:
        """p_copper / tau^2 at the output [W / (N m)^2] = 1 / (G k_m)^2."""
        return 1.0 / (self.gear_ratio * self.motor_constant) ** 2


GO1_HIP_THIGH = ActuatorType("go1_hip_thigh", 6.33, 0.147, (0.147, 0.22))
GO1_KNEE = ActuatorType("go1_knee", 6.33 * 1.5, 0.147, (0.147, 0.22))
AK80_6 = ActuatorType("ak80_6", 6.0, 0.2206, (0.2206, 0.28))


@dataclass(frozen=True)
class MotorModel:
    """The actuator type of each of the 16 actuated joints (project order: hip, thigh, calf per leg, then the four
    wheels), the regeneration rule and the electronics draw."""

    leg_types: tuple[ActuatorType, ActuatorType, ActuatorType] = (GO1_HIP_THIGH, GO1_HIP_THIGH, GO1_KNEE)
    wheel_type: ActuatorType = AK80_6
    regeneration: float = 0.0
    """Share of generated (negative) joint power the battery takes back, in [0, 1]; 0: none (a joint that brakes
    costs nothing and returns nothing)."""
    shared_bus: bool = True
    """The joints share the robot's DC bus, so a braking joint's generated power feeds the others and only the
    robot's net power is settled with the battery (the Go1's drivers hang on one battery bus); False settles each
    joint with the battery on its own (a braking joint's power is lost even while another joint draws)."""
    electronics_w: float = 0.0
    """Constant draw of the computers and idle drivers [W], reported apart from the joints' power (0: left out)."""
    types: tuple[ActuatorType, ...] = field(init=False)

    def __post_init__(self) -> None:
        if not 0.0 <= self.regeneration <= 1.0:
            raise ValueError(f"regeneration must be in [0, 1], got {self.regeneration}")
        if not (self.electronics_w >= 0 and math.isfinite(self.electronics_w)):
            raise ValueError(f"electronics_w must be a finite number >= 0, got {self.electronics_w}")
        legs = self.leg_types * (NUM_LEG_JOINTS // 3)
        object.__setattr__(self, "types", legs + (self.wheel_type,) * (NUM_ACTUATED - NUM_LEG_JOINTS))

    def per_joint(self) -> dict[str, list[float]]:
        """The kernel's per-joint inputs (16 each): copper coefficient [W / (N m)^2], Coulomb [N m] and viscous
        [N m s / rad] friction."""
        return {
            "copper": [t.copper_coefficient for t in self.types],
            "coulomb": [t.coulomb_friction for t in self.types],
            "viscous": [t.viscous_friction for t in self.types],
        }

    def kernel_inputs(self) -> dict:
        """The power kernel's motor inputs (``wqwarp.kernels.power.MotorArrays.build(**model.kernel_inputs())``):
        the per-joint coefficients of :meth:`per_joint` and the bus rule."""
        return {**self.per_joint(), "regeneration": self.regeneration, "shared_bus": self.shared_bus}

    def joint_power(self, j: int, tau: float, qd: float) -> float:
        """Bus power of joint ``j`` at output torque ``tau`` [N m] and speed ``qd`` [rad/s] [W], negative while it
        generates (the reference the Warp kernel is tested against)."""
        t = self.types[j]
        return (
            tau * qd + t.copper_coefficient * tau * tau + (t.coulomb_friction + t.viscous_friction * abs(qd)) * abs(qd)
        )

    def battery_power(self, tau, qd) -> float:
        """What the battery pays [W] for the 16 joints' output torques ``tau`` [N m] and speeds ``qd`` [rad/s]
        (sequences in project order), under this model's bus and regeneration rules; electronics not included."""
        p = [self.joint_power(j, float(tau[j]), float(qd[j])) for j in range(NUM_ACTUATED)]
        settle = lambda x: x if x >= 0.0 else self.regeneration * x  # noqa: E731
        return settle(sum(p)) if self.shared_bus else sum(settle(x) for x in p)
