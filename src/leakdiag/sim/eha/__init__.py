"""The electrohydrostatic actuator (EHA, thesis Ch. 3, Sec. 4.6): parameters (Table 3-1), model
(Eqs. 3-1 to 3-19), flow laws, analytic Jacobian, drive signals, the ROS2 integrator and
``simulate_eha``. Public names are re-exported by :mod:`leakdiag.sim`; this package imports
nothing itself so that its modules can be imported one by one without cycles.
"""
