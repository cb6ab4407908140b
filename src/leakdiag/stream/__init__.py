"""leakdiag.stream"""
