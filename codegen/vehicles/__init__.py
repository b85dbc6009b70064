"""svbi.codegen.vehicles"""
