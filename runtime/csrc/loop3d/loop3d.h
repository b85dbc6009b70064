/*
 * The compiled loop of the 3D localized-dynamic step (docs/c-backend.md, "The 3D loop"): the step
 * of svbi.runtime.methods.localized3d.LocalizedDynamic3D (with _Step3D of coupled3d.py) on the
 * CasADi-emitted contact kernels of generated/contact3d/. The structs that Python hands in
 * (setup3d_t, state3d_t, chunk3d_t, info3d_t) and the status codes S3_* are generated:
 * generated/solver3d/svbi_loop3d_types.h, from the field lists of svbi.codegen.loop3d_abi, which
 * also give the ctypes mirrors of svbi.runtime.backends.c.stepper3d (svbi3d_sizes() lets Python
 * check the layout at load). No function allocates: the caller gives one double and one int
 * workspace of the sizes svbi3d_workspace returns, carved once (setup3d.c). Files, one job each: setup3d.c (workspace, kernel maps),
 * linalg3d.c (band and dense solves), rows3d.c (the contact kernels of a wheelset), vehicle3d.c
 * (per-car blocks), span3d.c (the span's loads and solves), interface3d.c (the interface
 * iteration), active3d.c (the active set and the complementarity solves), impact3d.c (plastic
 * impact), creep3d.c (explicit creep forces) and step3d.c (the step and the loop).
 */
#ifndef SVBI_LOOP3D_H
#define SVBI_LOOP3D_H

#include "contact3d.h"
#include "svbi_loop3d_types.h"

#define NZ3 16
#define PER_WS 4
#define NEWTON_ITERATIONS3 20
#define NEWTON_TOLERANCE3 1e-13
#define STAGNATION3 1e-9
#define PIVOT_TRIES3 3

/* The pivoting rule of unilateral.Pivoting (block pivots, then Murty's least-index rule). */
typedef struct {
  int n, best, tries, passes;
} pivot3_t;

/* The workspace, carved once (setup3d.c). */
typedef struct {
  const setup3d_t* S;
  int* map;   /* dense position of each nonzero of each kernel output */
  int* mapn;  /* nnz of each kernel output */
  int* mapr;  /* rows x cols of each (dense size) */
  double* nz; /* a kernel's nonzeros (MAX_OUTPUT_DENSE x 2) */
  double* kw; /* CasADi work */
  casadi_int kiw[SVBI_CONTACT3D_MAX_SZ_IW + 1];
  /* vehicle */
  double *fV, *PtV, *QtV, *dq0, *dq, *dqn, *qk, *qdk, *qddk, *gv, *tV;
  double *AVt, *MVit; /* the cars' blocks of S->AV, S->MVi by columns (veh_mul3) */
  /* span */
  double *PB, *QB, *fBfull, *fB, *uf0, *uk, *udk, *uddk, *bw, *tF, *tB;
  const double *Q0, *Q1, *Q2; /* support targets of the step (NULL without) */
  /* contacts */
  int *fidx, *ondeck; /* nW x 12 free indices of the element DOFs (-1: held or ground), nW */
  int* held_of;       /* nB: the support of each held DOF (-1: none; the last if several) */
  const double* gz;   /* the ground under the wheelsets (3 x nW x 12) of the step, or NULL */
  double *grad, *res, *jac, *gap; /* nW x 4 x 16, nW x 4, nW x 4 x 16, nW x 4 */
  double *uc0, *ucn;              /* nW x 12: span displacements at the contact DOFs */
  double *A, *rhs, *lam, *lamn, *start, *force, *ggap;
  int *active, *landing, *in_contact, *idx, *piv;
  int *lu_last, *lu_first; /* the interface factors' profile (lu_factor3) */
  int *pair, *sel, *act_of; /* nW x nW coupling (1: same car, 2: same structure), cached elements of
                             * each pair's S block, the active row of each constraint (-1) */
  double* Sblk;              /* nW x nW x 144: S between the elements of two wheelsets (0 at held DOFs) */
  double* SblkT;             /* each block of Sblk transposed */
  int *plist, *pstart; /* the coupled ordered pairs w nW + v (pair != 0), by w: [pstart[w], pstart[w + 1]) */
  int* seen;           /* 1 + nW: the elements the couplings were found for (couple) */
  /* of an iteration, per wheelset: its active constraints (ncon, 4 each), the element DOFs (free)
   * where their gradients (nzg, 12 each) and their rows (nzr) are nonzero, and those entries (gc,
   * rc: 4 x 12 each); rv the rows' vehicle part (4 x 4) */
  int *ncon, *con, *nng, *nzg, *nnr, *nzr;
  double *gc, *rc, *rv;
  double *hw, *hwp; /* nW x 12: the contact forces' loads on their elements, now and before */
  double *dqh, *uch, *hh2; /* a chord iteration's state of the forces with the new gradients (nV, 12 nW, 12 nW) */
  pivot3_t pv; /* pivoting of the active set */
  long iterations, passes, factorizations;
  /* impact */
  double *GV, *AVm, *ABm, *G, *gt, *gtt, *gtt2, *want, *imp, *jump, *x0, *y, *sub, *subr;
  int *basic, *cand, *bad, *held2;
  int* nzb; /* nF: the span DOFs the damping forces of a velocity jump load */
  double zero16[NZ3];
  double* geom; /* nW x 8: the kernels' geometry of each wheelset (S->geom, entry 7 the length of
                 * the element it stands on: locate) */
} work3d_t;

/* entry points (step3d.c) */
int svbi3d_sizes(long* out);
int svbi3d_workspace(const setup3d_t* S, long* n_double, long* n_int);
int svbi3d_run(const setup3d_t* S, state3d_t* X, chunk3d_t* C, double* work, int* iwork, long n0, long k,
               info3d_t* I);
/* gaps of the state (2 nW normal, then 2 nW flange), at element/xi/irr/ground as given */
int svbi3d_gaps(const setup3d_t* S, const state3d_t* X, const int* element, const double* xi,
                const double* irr, const double* ground, double* work, int* iwork, double* out);

/* setup3d.c */
void w3_carve(const setup3d_t* S, work3d_t* W, double* work, int* iwork, long* nd, long* ni);
/* linalg3d.c */
void band_solve3(const double* L, int n, int p, double* b);
void band_solve3_2(const double* L, int n, int p, double* b, double* b2);
int lu_solve3(double* A, int n, double* b, int* piv);
int lu_factor3(double* A, int n, int* piv, int* last, int* first);
void lu_back3(const double* A, int n, const int* piv, const int* last, const int* first, double* b);
/* rows3d.c: kernel k (SVBI_CONTACT3D_K_*) at the wheelset's z = [q_w, u_e] (rates zd, zdd) */
int kcall3(work3d_t* W, int k, int w, const double* z, const double* zd, const double* zdd, double xi,
           const double* irr, const double* coef, double* out0, double* out1);
int gradients3(work3d_t* W, int w, const double* z, const double* zd, const double* zdd, double xi,
               const double* irr);
#define ROWS_ITERATE 0
#define ROWS_CHECK 1
#define ROWS_CHORD 2
int rows_needed3(work3d_t* W, int w, const double* z, const double* zd, const double* zdd, double xi,
                 const double* irr, int use);
void zvec3(const work3d_t* W, int w, const double* q, const double* u, const double* ground, double* z);
/* vehicle3d.c */
void veh_transpose3(const setup3d_t* S, const double* blocks, double* out);
void veh_mul3(const setup3d_t* S, const double* blocks_t, const double* x, double* y, int add);
/* span3d.c */
void csr_mul3(int n, const int* ptr, const int* idx, const double* val, const double* x, double* y, int add);
void span_solve3(work3d_t* W, double* bfree);
void span_solve3_2(work3d_t* W, double* b, double* b2);
void span_rates3(work3d_t* W, const double* u, double* ud, double* udd);
/* interface3d.c */
int iterate_rows3(work3d_t* W, const state3d_t* X, const double* uc, const double* xi, const double* irr,
                  int use);
int interface3(work3d_t* W, const state3d_t* X, const int* el, const double* xi, const double* irr);
/* active3d.c */
void pivot_reset3(pivot3_t* P, int n);
int pivot_flips3(pivot3_t* P, int* bad, int n);
int complementary3(work3d_t* W, const double* G, int n, const double* want, const double* x0,
                   const int* candidates, double* y, int* basic, int code);
/* impact3d.c */
int impact3(work3d_t* W, state3d_t* X, const int* el, const double* xi, const double* irr, int* dropped);
/* creep3d.c */
int creep3(work3d_t* W, state3d_t* X, const int* el, const double* xi, const double* irr);

#endif /* SVBI_LOOP3D_H */
