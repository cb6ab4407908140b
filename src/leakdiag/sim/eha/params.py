"""Parameters of the electrohydrostatic actuator (EHA) model, thesis Table 3-1.

:class:`EHAParams` is a frozen dataclass with SI units in every field name. Published values of
Table 3-1 are named constants below; values the thesis does not give (or prints inconsistently)
are decided here and justified in ``docs/models.md`` (section "EHA"). :meth:`EHAParams.to_array`
packs the parameters into the float64 vector read by the Numba right-hand side
:func:`leakdiag.sim.eha.model.eha_rhs`; the ``P_*`` integers are the positions in that vector.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from leakdiag.sim.leak import LPM_PER_M3S

__all__ = ["EHAParams", "RPM_TO_RAD_PER_S", "N_PARAMS"]

RPM_TO_RAD_PER_S = 2.0 * math.pi / 60.0
PSI_TO_PA = 6894.757

# --- Table 3-1 (published values) ---------------------------------------------------------
PRELOAD_FORCE_N = 25.0  # Table 3-1, F_pr
MASS_KG = 12.3  # Table 3-1, M_eq
VISCOUS_DAMPING_N_S_PER_M = 300.0  # Table 3-1, F_v
STROKE_M = 0.6  # Table 3-1, L
PISTON_AREA_M2 = 633e-6  # Table 3-1, A_A = A_B (double-rod cylinder)
MOTOR_PUMP_DAMPING_N_M_S_PER_RAD = 0.0004855  # Table 3-1, B_M
VELOCITY_THRESHOLD_M_PER_S = 0.01  # Table 3-1, V_th
PUMP_DISPLACEMENT_M3_PER_REV = 4.9e-6  # Table 3-1 and Sec. 3.2, q_b = 4.9 cm^3/rev
BULK_MODULUS_PA = 689e6  # Table 3-1, beta
MOTOR_RESISTANCE_OHM = 0.73  # Table 3-1, R_c
MOTOR_INDUCTANCE_H = 3.55e-3  # Table 3-1, L_c (printed "3.5510^-3")
BACK_EMF_V_S_PER_RAD = 0.6963  # Table 3-1, C_e
INERTIA_KG_M2 = 0.000874  # Table 3-1, J_m
TORQUE_CONSTANT_N_M_PER_A = 0.6963  # Table 3-1, C_m
FLUID_DENSITY_KG_PER_M3 = 847.0  # Table 3-1, rho
ORIFICE_DISCHARGE_COEFFICIENT = 0.92  # Table 3-1, C_d
LINE_DIAMETER_M = 7e-3  # Table 3-1, d_line

# --- decided values (docs/models.md, "EHA: decisions") -------------------------------------
CHAMBER_VOLUME_M3 = 234e-6  # Table 3-1 prints 234 mm^3; Table 2-1 (same cylinder) 234 cm^3
ORIFICE_AREA_RATIO = 0.1  # Eq. 3-8 k; k * pi d^2 / 4 = 3.85 mm^2, the area printed in Table 3-1
LINE_VOLUME_M3 = 50e-6  # not given: ~1 m of 7 mm steel tube + pump port, filter, valve block
MAX_PUMP_SPEED_RPM = 4000.0  # Sec. 3.2 prints 400 rpm; read as 4000 (see docs)
COMMAND_LIMIT_V = 10.0  # +-10 V analog command of the SSt-6000 drive (Sec. 3.2), assumed
SPEED_COMMAND_GAIN = MAX_PUMP_SPEED_RPM * RPM_TO_RAD_PER_S / COMMAND_LIMIT_V  # 41.9 rad/s per V
SPEED_KP_V_S_PER_RAD = 0.5  # PI speed loop, Eq. 3-1 k_p (not given)
SPEED_KI_V_PER_RAD = 20.0  # PI speed loop, Eq. 3-1 K_i (not given)
MOTOR_VOLTAGE_LIMIT_V = 310.0  # DC bus of a 220 V AC drive (Sec. 3.2), sqrt(2) * 220
ACCUMULATOR_PRESSURE_PA = 1.4e6  # charge pressure, ~200 psi (not given)
CHECK_VALVE_AREA_M2 = 20e-6  # accumulator check valves (not given)
PUMP_INTERNAL_LEAKAGE_M3_PER_S_PA = 6.5e-13  # ~2 % of rated flow at 10 MPa (not given)
PUMP_EXTERNAL_LEAKAGE_M3_PER_S_PA = 1.6e-13  # case drain per line, ~0.5 % at 10 MPa
POSITION_GAIN_V_PER_M = 400.0  # closed-loop outer loop (Sec. 7.2 future work), ~20 rad/s
SPRING_STIFFNESS_N_PER_M = 20e3  # load="spring" (Sec. 4.6 "load emulating a spring")
LAMINAR_TRANSITION_PA = 1e4  # orifice laminar core, numerical regularisation (see docs)
CHECK_VALVE_OPENING_PA = 5e4  # poppet fully open 0.05 MPa below the charge pressure
END_STOP_STIFFNESS_N_PER_M = 1e8  # rigid cylinder end caps, numerical
END_STOP_DAMPING_N_S_PER_M = 5e4
SENSOR_RANGE_PA = 3000.0 * PSI_TO_PA  # Sec. 3.2: pressure sensors up to 3000 psi

# Positions in the parameter vector (to_array). Fields first, in declaration order, then derived.
_FIELD_ORDER = (
    "preload_force_n", "mass_kg", "viscous_damping_n_s_per_m", "stroke_m", "piston_area_m2",
    "chamber_volume_m3", "motor_pump_damping_n_m_s_per_rad", "velocity_threshold_m_per_s",
    "pump_displacement_m3_per_rev", "bulk_modulus_pa", "motor_resistance_ohm",
    "motor_inductance_h", "back_emf_v_s_per_rad", "inertia_kg_m2", "torque_constant_n_m_per_a",
    "fluid_density_kg_per_m3", "orifice_discharge_coefficient", "line_diameter_m",
    "orifice_area_ratio", "line_volume_m3", "max_pump_speed_rad_per_s", "command_limit_v",
    "speed_command_gain_rad_per_s_per_v", "speed_kp_v_s_per_rad", "speed_ki_v_per_rad",
    "motor_voltage_limit_v", "accumulator_pressure_pa", "check_valve_area_m2",
    "pump_internal_leakage_m3_per_s_pa", "pump_external_leakage_m3_per_s_pa",
    "position_gain_v_per_m", "spring_stiffness_n_per_m", "laminar_transition_pa",
    "end_stop_stiffness_n_per_m", "end_stop_damping_n_s_per_m", "check_valve_opening_pa",
)
(P_FPR, P_M, P_FV, P_STROKE, P_AREA, P_V0, P_BM, P_VTH, P_QB, P_BETA, P_RC, P_LC, P_CE, P_JM,
 P_CM, P_RHO, P_CD, P_DLINE, P_KORI, P_VLINE, P_WMAX, P_UMAX, P_KW, P_KP, P_KI, P_VMAX, P_PACC,
 P_ACV, P_CINT, P_CEXT, P_KX, P_KS, P_PTR, P_KSTOP, P_CSTOP, P_PCV) = range(len(_FIELD_ORDER))
P_KFREE = len(_FIELD_ORDER)  # C_d sqrt(2/rho) A_line, free direction (Eqs. 3-9, 3-11)
P_KRESTR = P_KFREE + 1  # C_d sqrt(2/rho) A_ori, restricted direction (Eqs. 3-10, 3-12)
P_KCV = P_KFREE + 2  # C_d sqrt(2/rho) A_cv, accumulator check valves
P_CLOSED = P_KFREE + 3  # 1.0 in closed-loop position mode, else 0.0
N_PARAMS = P_CLOSED + 1


@dataclass(frozen=True)
class EHAParams:
    """Physical and controller parameters of the EHA rig (Table 3-1 plus documented decisions).

    Every field carries its SI unit in its name. Defaults are the published Table 3-1 values where
    the table gives them and decided values elsewhere (see ``docs/models.md``, section EHA).
    Vary a set with :func:`dataclasses.replace`.

    Parameters
    ----------
    preload_force_n : float
        Seal preload (Coulomb) friction at the piston, N (Table 3-1 ``F_pr``).
    mass_kg : float
        Combined mass of piston and rod, kg (``M_eq``).
    viscous_damping_n_s_per_m : float
        Viscous damping of the piston, N s/m (``F_v``), at the reference temperature.
    stroke_m : float
        Actuator stroke, m (``L``); the piston moves in ``[-L/2, L/2]`` around mid-stroke.
    piston_area_m2 : float
        Piston area on either side, m^2 (``A_A = A_B``).
    chamber_volume_m3 : float
        Fluid volume of either chamber at mid-stroke, m^3 (``V``).
    motor_pump_damping_n_m_s_per_rad : float
        Viscous damping of motor and pump, N m s/rad (``B_M``).
    velocity_threshold_m_per_s : float
        Velocity below which the preload friction is proportional to velocity, m/s (``V_th``).
    pump_displacement_m3_per_rev : float
        Pump displacement, m^3/rev (``q_b``).
    bulk_modulus_pa : float
        Effective fluid bulk modulus, Pa (``beta``), at the reference temperature.
    motor_resistance_ohm, motor_inductance_h : float
        Motor winding resistance (Ohm) and inductance (H) (``R_c``, ``L_c``).
    back_emf_v_s_per_rad : float
        Back-EMF constant, V s/rad (``C_e``).
    inertia_kg_m2 : float
        Moment of inertia of motor and pump, kg m^2 (``J_m``).
    torque_constant_n_m_per_a : float
        Torque constant, N m/A (``C_m``).
    fluid_density_kg_per_m3 : float
        Fluid density, kg/m^3 (``rho``).
    orifice_discharge_coefficient : float
        Discharge coefficient of the line orifices (``C_d``), also used for the check valves.
    line_diameter_m : float
        Inner diameter of the lines, m (``d_line``); line area is ``pi d^2 / 4``.
    orifice_area_ratio : float
        ``k`` of Eq. 3-8, restricted over free orifice area, in (0, 1].
    line_volume_m3 : float
        Fluid volume of each pump-side line, m^3 (``V_1 = V_2``).
    max_pump_speed_rad_per_s : float
        Motor/pump speed limit, rad/s (the speed command saturates here).
    command_limit_v : float
        Saturation of the drive's analog command, V.
    speed_command_gain_rad_per_s_per_v : float
        Drive gain from command voltage to speed set-point ``omega_d``, rad/s per V.
    speed_kp_v_s_per_rad, speed_ki_v_per_rad : float
        Proportional (V s/rad) and integral (V/rad) gains of the PI speed loop (Eq. 3-1).
    motor_voltage_limit_v : float
        Saturation of the motor voltage ``V`` (drive DC bus), V.
    accumulator_pressure_pa : float
        Accumulator charge pressure, Pa; check valves keep the lines above it.
    check_valve_area_m2 : float
        Open area of each accumulator check valve, m^2.
    pump_internal_leakage_m3_per_s_pa : float
        Laminar cross-port leakage of the pump, m^3/(s Pa).
    pump_external_leakage_m3_per_s_pa : float
        Laminar case-drain leakage from each line to the accumulator, m^3/(s Pa).
    position_gain_v_per_m : float
        Proportional gain of the outer position loop (closed-loop mode), V/m.
    spring_stiffness_n_per_m : float
        Stiffness of the load spring used by ``load="spring"``, N/m.
    laminar_transition_pa : float
        Pressure drop below which the orifice laws become linear (regularisation), Pa.
    end_stop_stiffness_n_per_m, end_stop_damping_n_s_per_m : float
        Contact stiffness (N/m) and damping (N s/m) of the cylinder end caps.
    check_valve_opening_pa : float
        Pressure difference over which a check valve goes from closed to fully open, Pa.

    Raises
    ------
    TypeError
        If a field is not a number.
    ValueError
        If a field is not finite, is negative, or a field that must be positive is zero;
        the message names the field and its value.

    Examples
    --------
    >>> p = EHAParams()
    >>> round(p.rated_pump_flow_lpm, 2)   # 4.9 cm^3/rev at 4000 rpm
    19.6
    >>> round(p.line_area_m2 * 1e6, 2)    # pi (7 mm)^2 / 4
    38.48
    >>> EHAParams(mass_kg=-1.0)
    Traceback (most recent call last):
    ...
    ValueError: mass_kg=-1.0 must be a finite number > 0
    """

    preload_force_n: float = PRELOAD_FORCE_N
    mass_kg: float = MASS_KG
    viscous_damping_n_s_per_m: float = VISCOUS_DAMPING_N_S_PER_M
    stroke_m: float = STROKE_M
    piston_area_m2: float = PISTON_AREA_M2
    chamber_volume_m3: float = CHAMBER_VOLUME_M3
    motor_pump_damping_n_m_s_per_rad: float = MOTOR_PUMP_DAMPING_N_M_S_PER_RAD
    velocity_threshold_m_per_s: float = VELOCITY_THRESHOLD_M_PER_S
    pump_displacement_m3_per_rev: float = PUMP_DISPLACEMENT_M3_PER_REV
    bulk_modulus_pa: float = BULK_MODULUS_PA
    motor_resistance_ohm: float = MOTOR_RESISTANCE_OHM
    motor_inductance_h: float = MOTOR_INDUCTANCE_H
    back_emf_v_s_per_rad: float = BACK_EMF_V_S_PER_RAD
    inertia_kg_m2: float = INERTIA_KG_M2
    torque_constant_n_m_per_a: float = TORQUE_CONSTANT_N_M_PER_A
    fluid_density_kg_per_m3: float = FLUID_DENSITY_KG_PER_M3
    orifice_discharge_coefficient: float = ORIFICE_DISCHARGE_COEFFICIENT
    line_diameter_m: float = LINE_DIAMETER_M
    orifice_area_ratio: float = ORIFICE_AREA_RATIO
    line_volume_m3: float = LINE_VOLUME_M3
    max_pump_speed_rad_per_s: float = MAX_PUMP_SPEED_RPM * RPM_TO_RAD_PER_S
    command_limit_v: float = COMMAND_LIMIT_V
    speed_command_gain_rad_per_s_per_v: float = SPEED_COMMAND_GAIN
    speed_kp_v_s_per_rad: float = SPEED_KP_V_S_PER_RAD
    speed_ki_v_per_rad: float = SPEED_KI_V_PER_RAD
    motor_voltage_limit_v: float = MOTOR_VOLTAGE_LIMIT_V
    accumulator_pressure_pa: float = ACCUMULATOR_PRESSURE_PA
    check_valve_area_m2: float = CHECK_VALVE_AREA_M2
    pump_internal_leakage_m3_per_s_pa: float = PUMP_INTERNAL_LEAKAGE_M3_PER_S_PA
    pump_external_leakage_m3_per_s_pa: float = PUMP_EXTERNAL_LEAKAGE_M3_PER_S_PA
    position_gain_v_per_m: float = POSITION_GAIN_V_PER_M
    spring_stiffness_n_per_m: float = SPRING_STIFFNESS_N_PER_M
    laminar_transition_pa: float = LAMINAR_TRANSITION_PA
    end_stop_stiffness_n_per_m: float = END_STOP_STIFFNESS_N_PER_M
    end_stop_damping_n_s_per_m: float = END_STOP_DAMPING_N_S_PER_M
    check_valve_opening_pa: float = CHECK_VALVE_OPENING_PA

    # fields that may be zero (all others must be > 0)
    _MAY_BE_ZERO = frozenset({
        "preload_force_n", "viscous_damping_n_s_per_m", "motor_pump_damping_n_m_s_per_rad",
        "speed_kp_v_s_per_rad", "speed_ki_v_per_rad", "accumulator_pressure_pa",
        "pump_internal_leakage_m3_per_s_pa", "pump_external_leakage_m3_per_s_pa",
        "spring_stiffness_n_per_m", "end_stop_damping_n_s_per_m", "check_valve_area_m2",
    })

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"{f.name}={value!r} must be a number")
            v = float(value)
            if f.name in self._MAY_BE_ZERO:
                if not math.isfinite(v) or v < 0:
                    raise ValueError(f"{f.name}={value!r} must be a finite number >= 0")
            elif not math.isfinite(v) or v <= 0:
                raise ValueError(f"{f.name}={value!r} must be a finite number > 0")
            object.__setattr__(self, f.name, v)
        if self.orifice_area_ratio > 1.0:
            raise ValueError(f"orifice_area_ratio={self.orifice_area_ratio!r} must be in (0, 1]")
        half_swept = self.piston_area_m2 * self.stroke_m / 2.0
        if self.chamber_volume_m3 <= half_swept:
            raise ValueError(
                f"chamber_volume_m3={self.chamber_volume_m3!r} must exceed the half-stroke swept "
                f"volume piston_area_m2 * stroke_m / 2 = {half_swept!r} (a chamber would vanish)"
            )

    # ------------------------------------------------------------------ derived quantities
    @property
    def line_area_m2(self) -> float:
        """Line cross-section ``pi d_line^2 / 4``, m^2 (replaces Eq. 3-7, see docs)."""
        return math.pi * self.line_diameter_m**2 / 4.0

    @property
    def restricted_orifice_area_m2(self) -> float:
        """Restricted-direction orifice area ``k A_line``, m^2 (Eq. 3-8)."""
        return self.orifice_area_ratio * self.line_area_m2

    @property
    def pump_flow_per_rad_m3(self) -> float:
        """Pump flow per unit speed ``q_b / (2 pi)``, m^3/rad (Eq. 3-6)."""
        return self.pump_displacement_m3_per_rev / (2.0 * math.pi)

    @property
    def rated_pump_flow_m3_per_s(self) -> float:
        """Geometric pump flow at the speed limit, m^3/s."""
        return self.pump_flow_per_rad_m3 * self.max_pump_speed_rad_per_s

    @property
    def rated_pump_flow_lpm(self) -> float:
        """Geometric pump flow at the speed limit, L/min (to report leaks as % of it)."""
        return self.rated_pump_flow_m3_per_s * LPM_PER_M3S

    # ------------------------------------------------------------------ conversions
    def to_dict(self) -> dict[str, float]:
        """Field name -> value (plain floats), e.g. for recording metadata.

        Returns
        -------
        dict of str to float
        """
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> "EHAParams":
        """Build from a mapping of field names; unknown names raise.

        Parameters
        ----------
        values : dict
            Field name -> value; missing fields take their defaults.

        Returns
        -------
        EHAParams

        Raises
        ------
        ValueError
            If a key is not a field of :class:`EHAParams`.
        """
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ValueError(f"unknown EHAParams field(s) {unknown}; valid: {sorted(names)}")
        return cls(**dict(values))

    @classmethod
    def from_toml(cls, path: str | Path) -> "EHAParams":
        """Read parameters from a TOML file (top level or an ``[eha]`` table).

        Parameters
        ----------
        path : str or pathlib.Path
            TOML file whose keys are field names, e.g. ``mass_kg = 15.0``.

        Returns
        -------
        EHAParams

        Raises
        ------
        ValueError
            If the file holds an unknown key or a bad value (message names the file).
        """
        path = Path(path)
        with path.open("rb") as fh:
            data = tomllib.load(fh)
        if isinstance(data.get("eha"), dict):
            data = data["eha"]
        try:
            return cls.from_dict(data)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: {exc}") from None

    def to_array(self, closed_loop: bool = False) -> np.ndarray:
        """Pack into the float64 vector read by :func:`~leakdiag.sim.eha.model.eha_rhs`.

        Parameters
        ----------
        closed_loop : bool, default False
            Closed-loop position mode (the command is ``K_x (x_ref - x)``).

        Returns
        -------
        numpy.ndarray
            Shape ``(N_PARAMS,)``.
        """
        arr = np.zeros(N_PARAMS, dtype=np.float64)
        for i, name in enumerate(_FIELD_ORDER):
            arr[i] = getattr(self, name)
        k_or = self.orifice_discharge_coefficient * math.sqrt(2.0 / self.fluid_density_kg_per_m3)
        arr[P_KFREE] = k_or * self.line_area_m2
        arr[P_KRESTR] = k_or * self.restricted_orifice_area_m2
        arr[P_KCV] = k_or * self.check_valve_area_m2
        arr[P_CLOSED] = 1.0 if closed_loop else 0.0
        return arr
