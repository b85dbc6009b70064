"""svbi.runtime"""
