"""Virtual machines: reproducible units of the VCA and EHA rigs with per-unit tolerances.

Table 2-1 and Table 3-1 describe *one* rig. Real units of the same type differ within the
tolerances of their parts, and a detector fitted on one unit meets another. A machine is a
frozen dataclass of those per-unit deviations; :func:`draw_machine` draws unit ``n`` of a system
from its own random stream (independent of the ``seed`` that draws a run's noise and reference),
and :meth:`VCAMachine.apply_params` / :meth:`VCAMachine.apply_sensors` turn it into the
parameter objects the simulators use (:func:`dataclasses.replace`). Each range and its source is
in ``docs/models.md``, section "Virtual machines"; the constants below carry the same numbers.

The nominal machine (every factor 1, every offset 0, no filter) is the Table 2-1 / 3-1 unit and
leaves a simulation bit for bit as it was without a machine.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

import numpy as np

from leakdiag.sim.eha.params import EHAParams  # noqa: F401  (the doctests use it)
from leakdiag.sim.leak import LPM_PER_M3S, lpm_to_m3s
from leakdiag.sim.sensors import PRESSURE_FULL_SCALE_PA, SensorParams
from leakdiag.sim.vca.params import VCAParams

__all__ = [
    "VCAMachine",
    "EHAMachine",
    "draw_machine",
    "resolve_machine",
    "MACHINE_SYSTEMS",
]

#: Systems with virtual machines.
MACHINE_SYSTEMS = ("vca", "eha")
#: Entropy tag of the machine streams ("mach" in ASCII): unit n of a system always draws from
#: ``SeedSequence([n, system index, MACHINE_STREAM_TAG])``, never from a run's ``seed``.
MACHINE_STREAM_TAG = 0x6D616368

# --- tolerance bands (half-widths of uniform draws unless stated; docs/models.md) ----------
VALVE_FLOW_GAIN_TOL = 0.05  # +-5 % flow gain (inside the +-10 % rated-flow band of catalogues)
VALVE_NULL_OFFSET_TOL_V = 0.1  # +-1 % of the +-10 V rated input (null bias)
VALVE_NULL_SHIFT_TOL_V_PER_K = 0.02 * 10.0 / 38.0  # < 2 % of rated input per 38 K (null shift)
VALVE_BANDWIDTH_TOL = 0.20  # +-20 % natural frequency
VALVE_NULL_LEAKAGE_LPM = (0.05, 0.3)  # spool null leakage at the supply pressure, log-uniform
SUPPLY_PRESSURE_TOL = 0.02  # +-2 % relief / compensator setting
BULK_MODULUS_TOL = 0.10  # +-10 % entrained air, hose compliance
TRANSDUCER_OFFSET_TOL = 0.0025  # +-0.25 % of full scale zero error
TRANSDUCER_GAIN_TOL = 0.0025  # +-0.25 % span error
ANTIALIAS_CUTOFF_HZ = 250.0  # 2nd-order Butterworth at f_s / 4 for the 1 kHz rigs
ANTIALIAS_CUTOFF_TOL = 0.10  # +-10 % component tolerance of the analogue filter
PUMP_DISPLACEMENT_TOL = 0.02  # +-2 % geometric displacement
PUMP_LEAKAGE_FACTOR = (0.5, 2.0)  # x nominal pump leakage, log-uniform (new .. worn pump)
MOTOR_CONSTANT_TOL = 0.10  # +-10 % torque / back-EMF constant
MOTOR_RESISTANCE_TOL = 0.10  # +-10 % winding resistance


def _check_finite(obj, names) -> None:
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{name}={v!r} must be a finite number")
        object.__setattr__(obj, name, float(v))


def _check_positive_fields(obj, names) -> None:
    for name in names:
        v = getattr(obj, name)
        if not v > 0:
            raise ValueError(f"{name}={v!r} must be > 0")


def _check_unit(unit) -> int | None:
    if unit is None:
        return None
    if isinstance(unit, bool) or not isinstance(unit, (int, np.integer)) or unit < 0:
        raise ValueError(f"unit={unit!r} must be a non-negative integer or None")
    return int(unit)


class _MachineBase:
    """What both rigs' machines do, in one code path: checks, parameters, sensors, dict round trip.

    A subclass declares its deviations as fields and, as class attributes, how they apply:
    ``_APPLY`` rows ``(field, parameter, "mul" | "add")`` (the parameter is multiplied by, or
    offset by, the field) and ``_NON_NEGATIVE`` fields; every field ending in ``factor`` or
    ``gain`` must be > 0, every other one finite.
    """

    system: str = ""
    _APPLY: tuple = ()
    _NON_NEGATIVE: tuple = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "unit", _check_unit(self.unit))
        names = [f.name for f in fields(self) if f.name not in ("unit", "antialias_cutoff_hz")]
        _check_finite(self, names)
        _check_positive_fields(self, [n for n in names if n.endswith(("factor", "gain"))])
        for name in self._NON_NEGATIVE:
            if getattr(self, name) < 0:
                raise ValueError(f"{name}={getattr(self, name)!r} must be >= 0")
        if self.antialias_cutoff_hz is not None:
            _check_finite(self, ["antialias_cutoff_hz"])
            _check_positive_fields(self, ["antialias_cutoff_hz"])

    def apply_params(self, params):
        """The rig parameters of this unit: ``params`` with the deviations applied.

        Parameters
        ----------
        params : VCAParams or EHAParams
            Parameters without this unit's deviations (usually Table 2-1 / 3-1).

        Returns
        -------
        VCAParams or EHAParams
            ``params`` itself for a nominal machine.
        """
        if self.is_nominal:
            return params
        changes = {}
        for name, target, op in self._APPLY:
            value = getattr(self, name)
            base = getattr(params, target)
            changes[target] = base * value if op == "mul" else base + value
        return dataclasses.replace(params, **changes)

    def to_dict(self) -> dict:
        """Field name -> value plus ``system``, JSON-serialisable (for recording metadata).

        Returns
        -------
        dict
            ``{"system": ..., "unit": ..., <field>: <value>, ...}``.
        """
        return {"system": self.system, **dataclasses.asdict(self)}

    @classmethod
    def from_dict(cls, data: dict):
        """Rebuild a machine from :meth:`to_dict` output.

        Parameters
        ----------
        data : dict
            As written by :meth:`to_dict`; ``system`` must match the class.

        Returns
        -------
        VCAMachine or EHAMachine

        Raises
        ------
        ValueError
            If ``system`` does not match or a key is not a field.
        """
        data = dict(data)
        system = data.pop("system", cls.system)
        if system != cls.system:
            raise ValueError(f"system={system!r} does not match {cls.__name__} "
                             f"(system {cls.system!r})")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown {cls.__name__} field(s) {unknown}; known: {sorted(known)}")
        return cls(**data)

    @property
    def is_nominal(self) -> bool:
        """True if every deviation is at its nominal value (the Table 2-1 / 3-1 unit)."""
        return all(getattr(self, f.name) == f.default for f in fields(self) if f.name != "unit")

    def apply_sensors(self, sensors: SensorParams) -> SensorParams:
        """The sensor chain of this unit: transducer errors and anti-alias filter on top.

        Offsets add to those of ``sensors``, gains multiply them, the machine's anti-alias
        cutoff replaces theirs when it has one; a nominal machine returns ``sensors`` itself.

        Parameters
        ----------
        sensors : SensorParams
            The chain without this unit's errors.

        Returns
        -------
        SensorParams
        """
        if (self.p1_offset_pa == 0.0 and self.p2_offset_pa == 0.0 and self.p1_gain == 1.0
                and self.p2_gain == 1.0 and self.antialias_cutoff_hz is None):
            return sensors
        cutoff = (sensors.antialias_cutoff_hz if self.antialias_cutoff_hz is None
                  else self.antialias_cutoff_hz)
        return dataclasses.replace(
            sensors,
            p1_offset_pa=sensors.p1_offset_pa + self.p1_offset_pa,
            p2_offset_pa=sensors.p2_offset_pa + self.p2_offset_pa,
            p1_gain=sensors.p1_gain * self.p1_gain,
            p2_gain=sensors.p2_gain * self.p2_gain,
            antialias_cutoff_hz=cutoff,
        )


@dataclass(frozen=True)
class VCAMachine(_MachineBase):
    """One unit of the valve-controlled actuator rig: its deviations from Table 2-1.

    Parameters
    ----------
    unit : int or None, default None
        Unit number it was drawn as (None: the nominal or a hand-made unit).
    valve_flow_gain_factor : float, default 1.0
        Multiplies the valve flow gain :math:`K_v` (Eq. 2-2).
    valve_null_offset_v : float, default 0.0
        Null bias of the valve, V at its input (added to ``VCAParams.valve_null_offset_v``).
    valve_null_shift_v_per_k : float, default 0.0
        Null drift per kelvin of fluid temperature rise, V/K (the run's
        ``OperatingConditions.temperature_rise_k`` drives it).
    valve_bandwidth_factor : float, default 1.0
        Multiplies the valve natural frequency (Table 2-1: 150 Hz).
    valve_leakage_m3_per_s_pa : float, default 0.0
        Laminar spool-clearance conductance of each metering land, m^3/(s Pa) (added).
    supply_pressure_factor : float, default 1.0
        Multiplies the supply pressure (Table 2-1: 17.2 MPa).
    bulk_modulus_factor : float, default 1.0
        Multiplies the effective bulk modulus (Table 2-1: 689 MPa).
    p1_offset_pa, p2_offset_pa : float, default 0.0
        Zero error of the P1 / P2 transducers, Pa.
    p1_gain, p2_gain : float, default 1.0
        Span factor of the P1 / P2 transducers.
    antialias_cutoff_hz : float or None, default None
        -3 dB cutoff of the acquisition's anti-alias low-pass; None: no filter.

    Raises
    ------
    ValueError
        If a value is not finite, a factor or gain is not positive, a conductance is negative.

    Examples
    --------
    >>> VCAMachine().is_nominal
    True
    >>> m = VCAMachine(valve_flow_gain_factor=1.04, supply_pressure_factor=0.99)
    >>> p = m.apply_params(VCAParams())
    >>> round(p.valve_flow_gain_m1_5_per_kg0_5, 6), round(p.supply_pressure_pa)
    (0.030368, 17028000)
    """

    system = "vca"
    _APPLY = (
        ("valve_flow_gain_factor", "valve_flow_gain_m1_5_per_kg0_5", "mul"),
        ("valve_null_offset_v", "valve_null_offset_v", "add"),
        ("valve_null_shift_v_per_k", "valve_null_shift_v_per_k", "add"),
        ("valve_bandwidth_factor", "valve_natural_frequency_hz", "mul"),
        ("valve_leakage_m3_per_s_pa", "valve_leakage_m3_per_s_pa", "add"),
        ("supply_pressure_factor", "supply_pressure_pa", "mul"),
        ("bulk_modulus_factor", "bulk_modulus_pa", "mul"),
    )
    _NON_NEGATIVE = ("valve_leakage_m3_per_s_pa",)

    unit: int | None = None
    valve_flow_gain_factor: float = 1.0
    valve_null_offset_v: float = 0.0
    valve_null_shift_v_per_k: float = 0.0
    valve_bandwidth_factor: float = 1.0
    valve_leakage_m3_per_s_pa: float = 0.0
    supply_pressure_factor: float = 1.0
    bulk_modulus_factor: float = 1.0
    p1_offset_pa: float = 0.0
    p2_offset_pa: float = 0.0
    p1_gain: float = 1.0
    p2_gain: float = 1.0
    antialias_cutoff_hz: float | None = None

    def valve_null_leakage_lpm(self, params: VCAParams | None = None) -> float:
        """Spool null leakage from supply to tank of this unit, L/min: ``c_v (P_s - P_r)``.

        Parameters
        ----------
        params : VCAParams, optional
            Parameters the machine is applied to; default Table 2-1.

        Returns
        -------
        float
            Null leakage in L/min at this unit's supply pressure.
        """
        p = self.apply_params(VCAParams() if params is None else params)
        return p.valve_leakage_m3_per_s_pa * (p.supply_pressure_pa - p.tank_pressure_pa) * LPM_PER_M3S


@dataclass(frozen=True)
class EHAMachine(_MachineBase):
    """One unit of the electrohydrostatic actuator rig: its deviations from Table 3-1.

    Parameters
    ----------
    unit : int or None, default None
        Unit number it was drawn as (None: the nominal or a hand-made unit).
    pump_displacement_factor : float, default 1.0
        Multiplies the pump displacement :math:`q_b` (Table 3-1: 4.9 cm^3/rev).
    pump_internal_leakage_factor, pump_external_leakage_factor : float, default 1.0
        Multiply the pump's cross-port and case-drain leakage coefficients.
    motor_constant_factor : float, default 1.0
        Multiplies the torque constant :math:`C_m` and the back-EMF constant :math:`C_e`
        together (the same constant in SI units for a permanent-magnet motor).
    motor_resistance_factor : float, default 1.0
        Multiplies the winding resistance :math:`R_c`.
    bulk_modulus_factor : float, default 1.0
        Multiplies the effective bulk modulus.
    p1_offset_pa, p2_offset_pa, p1_gain, p2_gain, antialias_cutoff_hz
        Chamber-pressure transducer errors and anti-alias filter, as in :class:`VCAMachine`.

    Raises
    ------
    ValueError
        If a value is not finite or a factor or gain is not positive.

    Examples
    --------
    >>> p = EHAMachine(pump_displacement_factor=1.01).apply_params(EHAParams())
    >>> round(p.pump_displacement_m3_per_rev * 1e6, 4)
    4.949
    """

    system = "eha"
    _APPLY = (
        ("pump_displacement_factor", "pump_displacement_m3_per_rev", "mul"),
        ("pump_internal_leakage_factor", "pump_internal_leakage_m3_per_s_pa", "mul"),
        ("pump_external_leakage_factor", "pump_external_leakage_m3_per_s_pa", "mul"),
        ("motor_constant_factor", "torque_constant_n_m_per_a", "mul"),
        ("motor_constant_factor", "back_emf_v_s_per_rad", "mul"),
        ("motor_resistance_factor", "motor_resistance_ohm", "mul"),
        ("bulk_modulus_factor", "bulk_modulus_pa", "mul"),
    )

    unit: int | None = None
    pump_displacement_factor: float = 1.0
    pump_internal_leakage_factor: float = 1.0
    pump_external_leakage_factor: float = 1.0
    motor_constant_factor: float = 1.0
    motor_resistance_factor: float = 1.0
    bulk_modulus_factor: float = 1.0
    p1_offset_pa: float = 0.0
    p2_offset_pa: float = 0.0
    p1_gain: float = 1.0
    p2_gain: float = 1.0
    antialias_cutoff_hz: float | None = None


#: The machine class of each system.
MACHINES = {"vca": VCAMachine, "eha": EHAMachine}
#: What :func:`draw_machine` draws for each system, in stream order: ``(field, kind, band)``,
#: kind ``"factor"`` (1 + uniform within +-band), ``"offset"`` (uniform within +-band) or
#: ``"log"`` (log-uniform on the band); the sensor errors follow.
_DRAWS = {
    "vca": (
        ("supply_pressure_factor", "factor", SUPPLY_PRESSURE_TOL),
        ("valve_flow_gain_factor", "factor", VALVE_FLOW_GAIN_TOL),
        ("valve_null_offset_v", "offset", VALVE_NULL_OFFSET_TOL_V),
        ("valve_null_shift_v_per_k", "offset", VALVE_NULL_SHIFT_TOL_V_PER_K),
        ("valve_bandwidth_factor", "factor", VALVE_BANDWIDTH_TOL),
        ("bulk_modulus_factor", "factor", BULK_MODULUS_TOL),
        ("null_leakage_lpm", "log", VALVE_NULL_LEAKAGE_LPM),
    ),
    "eha": (
        ("pump_displacement_factor", "factor", PUMP_DISPLACEMENT_TOL),
        ("pump_internal_leakage_factor", "log", PUMP_LEAKAGE_FACTOR),
        ("pump_external_leakage_factor", "log", PUMP_LEAKAGE_FACTOR),
        ("motor_constant_factor", "factor", MOTOR_CONSTANT_TOL),
        ("motor_resistance_factor", "factor", MOTOR_RESISTANCE_TOL),
        ("bulk_modulus_factor", "factor", BULK_MODULUS_TOL),
    ),
}


def _uniform(rng: np.random.Generator, half_width: float) -> float:
    return float(rng.uniform(-half_width, half_width))


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _draw_sensor_errors(rng: np.random.Generator) -> dict:
    fs = PRESSURE_FULL_SCALE_PA
    return {
        "p1_offset_pa": _uniform(rng, TRANSDUCER_OFFSET_TOL * fs),
        "p2_offset_pa": _uniform(rng, TRANSDUCER_OFFSET_TOL * fs),
        "p1_gain": 1.0 + _uniform(rng, TRANSDUCER_GAIN_TOL),
        "p2_gain": 1.0 + _uniform(rng, TRANSDUCER_GAIN_TOL),
        "antialias_cutoff_hz": ANTIALIAS_CUTOFF_HZ * (1.0 + _uniform(rng, ANTIALIAS_CUTOFF_TOL)),
    }


def draw_machine(system: str, unit: int) -> VCAMachine | EHAMachine:
    """Draw unit number ``unit`` of a rig type: reproducible, independent of any run's seed.

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig type.
    unit : int
        Unit number, >= 0. The same number always gives the same machine; the stream is
        ``SeedSequence([unit, system index, MACHINE_STREAM_TAG])``.

    Returns
    -------
    VCAMachine or EHAMachine
        Deviations drawn uniformly within the tolerance bands (log-uniformly for leakages);
        ranges and sources in ``docs/models.md``, section "Virtual machines".

    Raises
    ------
    ValueError
        If ``system`` is unknown or ``unit`` is not a non-negative integer.

    Examples
    --------
    >>> m = draw_machine("vca", 17)
    >>> m.unit, m == draw_machine("vca", 17), m == draw_machine("vca", 18)
    (17, True, False)
    >>> 0.95 <= m.valve_flow_gain_factor <= 1.05 and abs(m.valve_null_offset_v) <= 0.1
    True
    """
    if system not in MACHINE_SYSTEMS:
        raise ValueError(f"system={system!r} must be one of {list(MACHINE_SYSTEMS)}")
    unit = _check_unit(unit)
    if unit is None:
        raise ValueError("unit=None must be a non-negative integer")
    index = MACHINE_SYSTEMS.index(system)
    rng = np.random.default_rng(np.random.SeedSequence([unit, index, MACHINE_STREAM_TAG]))
    values = {}
    for name, kind, band in _DRAWS[system]:  # in this order: the stream is part of the unit
        if kind == "factor":
            values[name] = 1.0 + _uniform(rng, band)
        elif kind == "offset":
            values[name] = _uniform(rng, band)
        else:
            values[name] = _log_uniform(rng, *band)
    if system == "vca":  # null leakage drawn in L/min at the unit's supply pressure
        ps = VCAParams().supply_pressure_pa * values["supply_pressure_factor"]
        values["valve_leakage_m3_per_s_pa"] = lpm_to_m3s(values.pop("null_leakage_lpm")) / ps
    return MACHINES[system](unit=unit, **values, **_draw_sensor_errors(rng))


def resolve_machine(machine, system: str) -> VCAMachine | EHAMachine:
    """The machine a simulator runs: nominal for None, drawn for an int, checked otherwise.

    Parameters
    ----------
    machine : None, int, VCAMachine or EHAMachine
        What the user passed as ``machine=``.
    system : {"vca", "eha"}
        The simulator's system.

    Returns
    -------
    VCAMachine or EHAMachine

    Raises
    ------
    TypeError
        If ``machine`` is a machine of the other system or not a machine at all.
    ValueError
        If an int is negative.

    Examples
    --------
    >>> resolve_machine(None, "eha") == EHAMachine()
    True
    """
    cls = MACHINES[system]
    if machine is None:
        return cls()
    if isinstance(machine, (int, np.integer)) and not isinstance(machine, bool):
        return draw_machine(system, int(machine))
    if isinstance(machine, cls):
        return machine
    raise TypeError(f"machine must be None, a unit number (int) or a {cls.__name__}; got "
                    f"{type(machine).__name__}")
