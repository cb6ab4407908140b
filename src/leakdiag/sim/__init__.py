"""leakdiag.sim"""
