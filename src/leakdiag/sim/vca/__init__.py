"""The valve-controlled actuator (VCA, thesis Ch. 2, Sec. 4.5): parameters (Table 2-1), model
(Eqs. 2-1 to 2-5), controller, operating conditions, the RK4 closed loop, ``simulate_vca`` and
a SciPy reference. Public names are re-exported by :mod:`leakdiag.sim`; this package imports
nothing itself so that its modules can be imported one by one without cycles.
"""
