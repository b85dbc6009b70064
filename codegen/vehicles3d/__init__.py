"""svbi.codegen.vehicles3d: built-in 3D vehicle topologies (not yet available in runs)."""
