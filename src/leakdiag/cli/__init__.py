"""leakdiag.cli"""
