"""leakdiag.studies"""
