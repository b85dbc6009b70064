"""svbi.templates"""
