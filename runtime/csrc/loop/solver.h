/*
 * svbi's C time loop: the whole Newmark loop of localized-dynamic, coupled-dynamic and
 * coupled-classic (docs/c-backend.md). The structs and status codes are in svbi_solver_types.h
 * (generated from the one field list of svbi.codegen.loop_abi, which also gives Python's ctypes
 * mirrors); the sizes of the vehicle topology in svbi_topology.h. No function allocates memory: the
 * caller provides one double and one int workspace of the sizes svbi_solver_workspace returns. The
 * functions keep no global state: separate workspaces run in separate threads.
 *
 * One build of these sources serves one vehicle topology (svbi_topology.h): the symbols carry no
 * model name, so two topologies do not link into one program.
 */
#ifndef SVBI_SOLVER_H
#define SVBI_SOLVER_H

#include "svbi_solver_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Workspace sizes (doubles, ints) for this setup. Returns 0. */
int svbi_solver_workspace(const svbi_solver_setup* setup, long* n_double, long* n_int);

/* Factor the constant matrices into the workspace; call once before the first run. */
int svbi_solver_init(const svbi_solver_setup* setup, double* work, int* iwork);

/* Advance steps n0 .. n0 + count - 1 (step n goes from t_n to t_{n+1} = (n + 1) dt). The state is
 * updated in place, outputs are written from row outputs->row on. Returns the status (also in
 * info->status); on an error info says at which step and what. */
int svbi_solver_run(const svbi_solver_setup* setup, svbi_solver_state* state,
                    const svbi_solver_excitation* excitation, svbi_solver_outputs* outputs, double* work,
                    int* iwork, long n0, long count, svbi_solver_info* info);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* SVBI_SOLVER_H */
