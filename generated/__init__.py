"""svbi.generated"""
