"""leakdiag.report"""
