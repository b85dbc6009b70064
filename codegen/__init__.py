"""svbi.codegen"""
