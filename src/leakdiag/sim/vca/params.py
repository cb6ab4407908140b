"""Parameters of the valve-controlled actuator (VCA), thesis Table 2-1 in SI units.

Every value cites its source; values the thesis does not give are marked *choice* and
explained in ``docs/models.md`` (section VCA).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from leakdiag._validation import check_positive
from leakdiag.sim.leak import LPM_PER_M3S

__all__ = ["VCAParams", "LEAK_MODELS", "LOADS", "P_INDEX", "N_PARAMS"]

SUPPLY_PRESSURE_PA = 17.2e6  # Table 2-1 (2500 psi, Sec. 2.2)
TANK_PRESSURE_PA = 0.0  # gauge; Eq. 2-2 measures chamber-to-tank drops from 0
MASS_KG = 12.3  # Table 2-1, combined mass of piston and rod
VISCOUS_DAMPING_N_S_PER_M = 250.0  # Table 2-1
STROKE_M = 0.6  # Table 2-1 (Sec. 2.2: 610 mm)
PISTON_AREA_M2 = 633e-6  # Table 2-1; = pi/4 (38.1^2 - 25.4^2) mm^2, Sec. 2.2
CHAMBER_VOLUME_M3 = 234e-6  # Table 2-1, each side, piston centred
ORIFICE_AREA_GRADIENT_M = 20.75e-3  # Table 2-1, 20.75 mm^2/mm
SPOOL_GAIN_M_PER_V = 0.0406e-3  # Table 2-1, 0.0406 mm/V
VALVE_FLOW_GAIN = 0.0292  # Table 2-1, m^(3/2)/kg^(1/2) (= Cd sqrt(2/rho))
VALVE_NATURAL_FREQUENCY_HZ = 150.0  # Table 2-1
VALVE_DAMPING_RATIO = 0.7  # Table 2-1
BULK_MODULUS_PA = 689e6  # Table 2-1
CONTROL_LIMIT_V = 10.0  # choice: +-10 V servo-valve input (Moog D765 standard input)
SPRING_STIFFNESS_N_PER_M = 50e3  # choice: "load emulating a spring" (Sec. 4.5), not given
END_STOP_STIFFNESS_N_PER_M = 1e8  # choice: stiff steel stop
END_STOP_DAMPING_N_S_PER_M = 3.5e4  # choice: about half the critical damping of the stop
VALVE_TRANSITION_PRESSURE_PA = 1e5  # choice: laminar regularisation of Eq. 2-2 below 1 bar
LEAK_TRANSITION_PRESSURE_PA = 1e4  # choice: laminar regularisation of Eq. 2-4 below 0.1 bar
COULOMB_FRICTION_N = 200.0  # choice: seal friction of a 38 mm double-rod cylinder (100-300 N)
COULOMB_VELOCITY_M_PER_S = 2e-3  # choice: tanh smoothing velocity of the Coulomb friction
# Per-unit imperfections of a real valve (docs/models.md, "Virtual machines"); 0 = the ideal
# critically lapped valve of Eq. 2-2, which is what Table 2-1 describes.
VALVE_NULL_OFFSET_V = 0.0  # null bias: valve input that gives zero spool displacement
VALVE_NULL_SHIFT_V_PER_K = 0.0  # null shift per kelvin of fluid temperature rise
VALVE_LEAKAGE_M3_PER_S_PA = 0.0  # laminar spool-clearance conductance of each metering land

#: Leak laws: Eq. 2-4 (turbulent) and Eq. 2-5 (laminar).
LEAK_MODELS: dict[str, int] = {"turbulent": 0, "laminar": 1}
#: Loads: none, or a linear spring centred at x = 0 (Sec. 4.5).
LOADS = ("none", "spring")

# Positions in the parameter vector (:meth:`VCAParams.to_array`, the ``params`` of ``vca_rhs``).
# Plain module-level integers, so Numba folds them into the compiled kernels like literals.
_PARAM_NAMES = (
    "area", "mass", "damping", "volume", "beta", "ps", "pt", "kv_flow", "w", "kv_spool",
    "omega_v", "zeta_v", "half_stroke", "k_end", "c_end", "k_spring", "f_coulomb",
    "v_coulomb", "leak_model", "ptr_valve", "ptr_leak", "u_null", "u_null_per_k",
    "c_valve_leak",
)
(P_AREA,  # A, piston area (Table 2-1)
 P_MASS,  # m (Table 2-1)
 P_DAMPING,  # d, viscous damping (Table 2-1)
 P_VOLUME,  # V, chamber volume at mid-stroke (Table 2-1)
 P_BETA,  # beta (Table 2-1)
 P_PS,  # P_s (Table 2-1)
 P_PT,  # P_r, tank
 P_KV_FLOW,  # K_v, valve flow gain (Eq. 2-2)
 P_W,  # w, orifice area gradient (Eq. 2-2)
 P_KV_SPOOL,  # k_v, spool gain
 P_OMEGA_V,  # omega_v = 2 pi f_v, valve natural frequency
 P_ZETA_V,  # xi, valve damping ratio
 P_HALF_STROKE,  # L / 2, end stops
 P_K_END,  # end-stop stiffness
 P_C_END,  # end-stop damping
 P_K_SPRING,  # load spring (0 without load)
 P_F_COULOMB,  # F_c, seal friction
 P_V_COULOMB,  # v_c, its tanh smoothing velocity
 P_LEAK_MODEL,  # 0 turbulent (Eq. 2-4), 1 laminar (Eq. 2-5)
 P_PTR_VALVE,  # laminar transition of the valve orifices (Eq. 2-2)
 P_PTR_LEAK,  # laminar transition of the turbulent leak (Eq. 2-4)
 P_U_NULL,  # valve null offset, V
 P_U_NULL_PER_K,  # valve null shift, V/K
 P_C_VALVE_LEAK,  # spool-clearance conductance of each metering land
 ) = range(len(_PARAM_NAMES))
N_PARAMS = len(_PARAM_NAMES)
#: Index of each entry of :meth:`VCAParams.to_array` (the ``params`` of ``vca_rhs``), by name.
P_INDEX: dict[str, int] = {name: i for i, name in enumerate(_PARAM_NAMES)}


@dataclass(frozen=True)
class VCAParams:
    """Physical parameters of the VCA (Table 2-1, SI units).

    Parameters
    ----------
    supply_pressure_pa : float, default 17.2e6
        Supply pressure :math:`P_s` (Table 2-1).
    tank_pressure_pa : float, default 0.0
        Tank (return) pressure :math:`P_r`, gauge.
    mass_kg : float, default 12.3
        Combined mass of piston and rod :math:`m` (Table 2-1).
    viscous_damping_n_s_per_m : float, default 250
        Effective viscous damping :math:`d` (Table 2-1).
    stroke_m : float, default 0.6
        Actuator stroke :math:`L`; the piston moves in ``[-L/2, L/2]`` about the centre.
    piston_area_m2 : float, default 633e-6
        Annulus area :math:`A` (Table 2-1).
    chamber_volume_m3 : float, default 234e-6
        Fluid volume :math:`V` on either side with the piston centred (Table 2-1).
    orifice_area_gradient_m : float, default 20.75e-3
        Valve orifice area gradient :math:`w` in m^2/m (Table 2-1).
    spool_gain_m_per_v : float, default 4.06e-5
        Spool position gain :math:`k_v` (Table 2-1).
    valve_flow_gain_m1_5_per_kg0_5 : float, default 0.0292
        Valve flow gain :math:`K_v` in m^(3/2)/kg^(1/2) (Table 2-1).
    valve_natural_frequency_hz : float, default 150
        Servo-valve natural frequency :math:`\\omega_v / 2\\pi` (Table 2-1).
    valve_damping_ratio : float, default 0.7
        Servo-valve damping ratio :math:`\\xi` (Table 2-1).
    bulk_modulus_pa : float, default 689e6
        Effective bulk modulus :math:`\\beta` (Table 2-1).
    control_limit_v : float, default 10.0
        Control signal saturation :math:`|u| \\le u_{max}` (choice: +-10 V valve input).
    spring_stiffness_n_per_m : float, default 50e3
        Spring stiffness used when ``load="spring"`` (choice; the thesis gives none).
    coulomb_friction_n : float, default 200.0
        Seal (Coulomb) friction, ``F_c tanh(v / v_c)`` (choice; Eq. 2-1 has only viscous
        damping, a real rig has seal friction, which is also what makes a no-load leak flow;
        0 gives Eq. 2-1 exactly).
    coulomb_velocity_m_per_s : float, default 2e-3
        Smoothing velocity :math:`v_c` of the Coulomb friction.
    end_stop_stiffness_n_per_m, end_stop_damping_n_s_per_m : float
        Contact model of the end stops at ``+-stroke/2`` (choice: 1e8 N/m, 3.5e4 N s/m).
    valve_transition_pressure_pa : float, default 1e5
        Pressure drop below which the orifice law turns laminar (regularisation, see Notes).
    leak_transition_pressure_pa : float, default 1e4
        The same for the turbulent leak law, Eq. 2-4.
    valve_null_offset_v : float, default 0.0
        Null bias :math:`u_0`: the spool sees :math:`u + u_0 + s_T \\Delta T(t)` (any sign;
        0 = the ideal valve of Table 2-1).
    valve_null_shift_v_per_k : float, default 0.0
        Null shift :math:`s_T` per kelvin of the fluid temperature rise :math:`\\Delta T(t)` of
        :class:`~leakdiag.sim.vca.conditions.OperatingConditions` (any sign).
    valve_leakage_m3_per_s_pa : float, default 0.0
        Laminar conductance :math:`c_v` of the radial clearance at each of the four metering
        lands: chamber 1 gains :math:`c_v(P_s - P_1) - c_v(P_1 - P_r)`, chamber 2 likewise; the
        null leakage from supply to tank is :math:`c_v (P_s - P_r)`.

    Raises
    ------
    ValueError
        If a value is not positive (friction may be 0, tank pressure must be below supply),
        or the centred volume cannot hold half a stroke (``V <= A L / 2``).

    Notes
    -----
    The square root of the orifice laws is regularised as
    :math:`\\mathrm{sgn}(\\Delta p)\\sqrt{|\\Delta p|} \\approx
    \\Delta p / (\\Delta p^2 + p_{tr}^2)^{1/4}`, exact to 0.25 % for
    :math:`|\\Delta p| > 10 p_{tr}` and with a finite slope at 0 (no infinite stiffness).

    Examples
    --------
    >>> p = VCAParams()
    >>> round(p.hydraulic_natural_frequency_rad_s, 1)
    438.0
    >>> round(p.rated_flow_lpm, 1)
    43.3
    >>> import dataclasses
    >>> dataclasses.replace(p, mass_kg=24.6).mass_kg
    24.6
    """

    supply_pressure_pa: float = SUPPLY_PRESSURE_PA
    tank_pressure_pa: float = TANK_PRESSURE_PA
    mass_kg: float = MASS_KG
    viscous_damping_n_s_per_m: float = VISCOUS_DAMPING_N_S_PER_M
    stroke_m: float = STROKE_M
    piston_area_m2: float = PISTON_AREA_M2
    chamber_volume_m3: float = CHAMBER_VOLUME_M3
    orifice_area_gradient_m: float = ORIFICE_AREA_GRADIENT_M
    spool_gain_m_per_v: float = SPOOL_GAIN_M_PER_V
    valve_flow_gain_m1_5_per_kg0_5: float = VALVE_FLOW_GAIN
    valve_natural_frequency_hz: float = VALVE_NATURAL_FREQUENCY_HZ
    valve_damping_ratio: float = VALVE_DAMPING_RATIO
    bulk_modulus_pa: float = BULK_MODULUS_PA
    control_limit_v: float = CONTROL_LIMIT_V
    spring_stiffness_n_per_m: float = SPRING_STIFFNESS_N_PER_M
    coulomb_friction_n: float = COULOMB_FRICTION_N
    coulomb_velocity_m_per_s: float = COULOMB_VELOCITY_M_PER_S
    end_stop_stiffness_n_per_m: float = END_STOP_STIFFNESS_N_PER_M
    end_stop_damping_n_s_per_m: float = END_STOP_DAMPING_N_S_PER_M
    valve_transition_pressure_pa: float = VALVE_TRANSITION_PRESSURE_PA
    leak_transition_pressure_pa: float = LEAK_TRANSITION_PRESSURE_PA
    valve_null_offset_v: float = VALVE_NULL_OFFSET_V
    valve_null_shift_v_per_k: float = VALVE_NULL_SHIFT_V_PER_K
    valve_leakage_m3_per_s_pa: float = VALVE_LEAKAGE_M3_PER_S_PA

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise TypeError(f"{f.name}={v!r} must be a number")
            if f.name in ("valve_null_offset_v", "valve_null_shift_v_per_k"):
                if not math.isfinite(v):
                    raise ValueError(f"{f.name}={v!r} must be a finite number")
            elif f.name in ("coulomb_friction_n", "tank_pressure_pa", "viscous_damping_n_s_per_m",
                            "spring_stiffness_n_per_m", "end_stop_damping_n_s_per_m",
                            "valve_leakage_m3_per_s_pa"):
                if not math.isfinite(v) or v < 0:
                    raise ValueError(f"{f.name}={v!r} must be a finite number >= 0")
            else:
                check_positive(v, f.name)
            object.__setattr__(self, f.name, float(v))
        if self.tank_pressure_pa >= self.supply_pressure_pa:
            raise ValueError(
                f"tank_pressure_pa={self.tank_pressure_pa!r} must be below "
                f"supply_pressure_pa={self.supply_pressure_pa!r}"
            )
        if self.chamber_volume_m3 <= self.piston_area_m2 * self.stroke_m / 2:
            raise ValueError(
                f"chamber_volume_m3={self.chamber_volume_m3!r} must exceed piston_area_m2 * "
                f"stroke_m / 2 = {self.piston_area_m2 * self.stroke_m / 2!r} (no dead volume)"
            )

    # ------------------------------------------------------------------ derived values
    @property
    def hydraulic_natural_frequency_rad_s(self) -> float:
        """:math:`\\omega_h = \\sqrt{2 \\beta A^2 / (m V)}`, Eq. 2-6, in rad/s."""
        return math.sqrt(
            2 * self.bulk_modulus_pa * self.piston_area_m2**2
            / (self.mass_kg * self.chamber_volume_m3)
        )

    @property
    def max_spool_m(self) -> float:
        """Spool displacement at full command, ``k_v * u_max`` (m)."""
        return self.spool_gain_m_per_v * self.control_limit_v

    @property
    def rated_flow_lpm(self) -> float:
        """No-load flow at full command and this supply pressure, L/min (Eq. 2-2).

        :math:`Q = K_v w k_v u_{max} \\sqrt{(P_s - P_r)/2}` (each orifice drops half the
        supply-to-tank pressure when the load pressure is 0); 43.3 L/min for Table 2-1. The
        valve's catalogue rating (34 L/min, Sec. 2.2) refers to other test conditions; see
        ``docs/models.md``.
        """
        dp = (self.supply_pressure_pa - self.tank_pressure_pa) / 2
        q = (self.valve_flow_gain_m1_5_per_kg0_5 * self.orifice_area_gradient_m
             * self.max_spool_m * math.sqrt(dp))
        return q * LPM_PER_M3S

    # ------------------------------------------------------------------ conversion
    def to_dict(self) -> dict[str, float]:
        """Field name -> value (SI), e.g. for recording metadata or TOML.

        Returns
        -------
        dict
            One entry per Table 2-1 field, SI units as in the field names.
        """
        return asdict(self)

    def to_array(self, leak_model: str = "turbulent", load: str = "none") -> np.ndarray:
        """Pack into the float64 ``params`` array of ``vca_rhs`` (layout :data:`P_INDEX`).

        Parameters
        ----------
        leak_model : {"turbulent", "laminar"}
            Leak law, Eq. 2-4 or Eq. 2-5.
        load : {"none", "spring"}
            With ``"none"`` the spring stiffness is stored as 0.

        Returns
        -------
        numpy.ndarray
            Shape ``(len(P_INDEX),)``.

        Raises
        ------
        ValueError
            If ``leak_model`` or ``load`` is unknown.
        """
        if leak_model not in LEAK_MODELS:
            raise ValueError(f"leak_model={leak_model!r} must be one of {list(LEAK_MODELS)}")
        if load not in LOADS:
            raise ValueError(f"load={load!r} must be one of {list(LOADS)}")
        vals = {
            "area": self.piston_area_m2, "mass": self.mass_kg,
            "damping": self.viscous_damping_n_s_per_m, "volume": self.chamber_volume_m3,
            "beta": self.bulk_modulus_pa, "ps": self.supply_pressure_pa,
            "pt": self.tank_pressure_pa, "kv_flow": self.valve_flow_gain_m1_5_per_kg0_5,
            "w": self.orifice_area_gradient_m, "kv_spool": self.spool_gain_m_per_v,
            "omega_v": 2 * math.pi * self.valve_natural_frequency_hz,
            "zeta_v": self.valve_damping_ratio, "half_stroke": self.stroke_m / 2,
            "k_end": self.end_stop_stiffness_n_per_m, "c_end": self.end_stop_damping_n_s_per_m,
            "k_spring": self.spring_stiffness_n_per_m if load == "spring" else 0.0,
            "f_coulomb": self.coulomb_friction_n, "v_coulomb": self.coulomb_velocity_m_per_s,
            "leak_model": float(LEAK_MODELS[leak_model]),
            "ptr_valve": self.valve_transition_pressure_pa,
            "ptr_leak": self.leak_transition_pressure_pa,
            "u_null": self.valve_null_offset_v,
            "u_null_per_k": self.valve_null_shift_v_per_k,
            "c_valve_leak": self.valve_leakage_m3_per_s_pa,
        }
        arr = np.empty(len(P_INDEX))
        for k, i in P_INDEX.items():
            arr[i] = vals[k]
        return arr

    @classmethod
    def from_toml(cls, path: str | Path) -> "VCAParams":
        """Load parameters from a TOML file; missing fields keep their Table 2-1 default.

        Parameters
        ----------
        path : str or pathlib.Path
            TOML file with field names as keys, at top level or in a ``[vca]`` table.

        Returns
        -------
        VCAParams

        Raises
        ------
        FileNotFoundError
            If the file does not exist.
        ValueError
            If a key is not a field (the message names it and the file) or a value is invalid.
        """
        import tomllib

        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"parameter file {path} does not exist")
        with path.open("rb") as fh:
            data = tomllib.load(fh)
        data = data.get("vca", data)
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{path}: unknown VCA parameter(s) {unknown}; known: {sorted(known)}")
        try:
            return cls(**data)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: {exc}") from None
