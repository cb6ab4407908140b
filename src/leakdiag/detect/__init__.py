"""leakdiag.detect"""
