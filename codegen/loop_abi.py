"""The C time loop's ABI, as plain data: struct members, status codes, method codes, the layout of
the contact-row table and the names of the generated glue files.

One definition for both sides of the loop: at generation time :mod:`svbi.codegen.loop_glue` renders
``generated/solver/svbi_solver_types.h`` and ``generated/frame2d/svbi_contact_rows.h`` from these
lists; at run time :mod:`svbi.runtime.backends.c.build` builds its ctypes mirrors of the structs from
the same lists, so the two cannot disagree (``svbi generate --check``, tests/backends/test_c_numerics.py).

This module imports nothing but the standard library (no SymPy, no Jinja2, no CasADi, no NumPy): the
runtime imports it on the run path, as it does :mod:`svbi.codegen.plain_types` and
:mod:`svbi.codegen.c_flags` (docs/architecture.md).
"""

from __future__ import annotations

from dataclasses import dataclass

ROW_BLOCKS = ("N0", "W_hat", "c_P_ue", "c_Q_ue", "T0", "T1")
"""Six-column blocks of the contact-row table, in column order; then ``ROW_SCALARS``. ``N0`` is
``W_N^B``, ``W_hat`` and the ``c_*`` columns the discrete aux-bridge row, ``T0`` and ``T1`` the
tangential row ``W_T^B`` and its x-derivative (creep)."""
ROW_SCALARS = ("c_P_ug", "c_Q_ug", "c_r", "c_r_x", "c_r_xx")
ROW_COLUMNS = 6 * len(ROW_BLOCKS) + len(ROW_SCALARS)

METHOD_CODES = {"localized-dynamic": 0, "coupled-dynamic": 1, "coupled-classic": 2}

STATUS_OK = 0
STATUS_NOT_FINITE = 1
STATUS_FORCE_LIMIT = 2
STATUS_GAP_LIMIT = 3
STATUS_SINGULAR = 4
STATUS_BANDWIDTH = 5
STATUS_NOT_SPD = 6
STATUS_INTERRUPTED = 7
STATUS_RANGE = 8
STATUS_EVENT = 9

STATUS_CODES = {
    "OK": STATUS_OK,
    "NOT_FINITE": STATUS_NOT_FINITE,
    "FORCE_LIMIT": STATUS_FORCE_LIMIT,
    "GAP_LIMIT": STATUS_GAP_LIMIT,
    "SINGULAR": STATUS_SINGULAR,
    "BANDWIDTH": STATUS_BANDWIDTH,
    "NOT_SPD": STATUS_NOT_SPD,
    "INTERRUPTED": STATUS_INTERRUPTED,
    "RANGE": STATUS_RANGE,
    "EVENT": STATUS_EVENT,
}
"""``SVBI_SOLVER_STATUS_<name>`` of the generated ``svbi_solver_types.h``."""
STATUS_NAMES = {
    STATUS_OK: "ok",
    STATUS_NOT_FINITE: "not finite",
    STATUS_FORCE_LIMIT: "contact force limit",
    STATUS_GAP_LIMIT: "gap limit",
    STATUS_SINGULAR: "singular matrix",
    STATUS_BANDWIDTH: "interface bandwidth exceeds the workspace",
    STATUS_NOT_SPD: "matrix not positive definite",
    STATUS_INTERRUPTED: "interrupted",
    STATUS_RANGE: "steps asked beyond the run (setup.steps)",
    STATUS_EVENT: "a wheel lifts off or lands (the step goes to the NumPy stepper)",
}


OUTPUT_NAMES = (
    "time",
    "midspan_uz",
    "midspan_ux",
    "deck_acceleration",
    "end_rotation",
    "pier_top_ux",
    "ground_uz",
    "ground_ux",
    "contact_force",
    "creep_force",
    "creepage",
    "irregularity",
    "carbody_uz",
    "carbody_az",
    "carbody_pitch",
    "vehicle_u",
    "vehicle_a",
    "gap_vehicle",
    "gap_bridge",
    "gap_support",
    "support_reaction",
)
"""Stored output arrays of the C loop, in the order of its ``Outputs`` struct's pointers."""


@dataclass(frozen=True)
class Field:
    """One member of a C struct: ``kind`` is a key of ``C_TYPES`` (``int*``, ``long*``, ``double*``:
    read-only arrays; ``mint*``, ``mdouble*``, ``mchar*``: arrays the loop writes)."""

    name: str
    kind: str
    doc: str


C_TYPES = {
    # the C type of every Field kind (svbi_solver_types.h, and svbi_loop3d_types.h of
    # svbi.codegen.loop3d_abi)
    "int": "int",
    "long": "long",
    "double": "double",
    "int*": "const int*",
    "long*": "const long*",
    "double*": "const double*",
    "mint*": "int*",
    "mdouble*": "double*",
    "mchar*": "unsigned char*",
    "ppoly": "svbi_ppoly",
    "ppoly*": "const svbi_ppoly*",
}


def F(name: str, kind: str, doc: str) -> Field:  # noqa: N802 - reads like a table row
    return Field(name, kind, doc)


PPOLY_FIELDS = [
    F("n", "int", "number of intervals (0: a step at x[0] from `left` to `right`)"),
    F("k", "int", "degree of every piece"),
    F("uniform", "int", "1 when the breaks are equally spaced to 1e-6 (O(1) interval guess, then exact)"),
    F("h", "double", "break spacing when uniform"),
    F("x", "double*", "n + 1 increasing breaks"),
    F(
        "c",
        "double*",
        "n x (k + 1) coefficients, the transpose of scipy.interpolate.PPoly.c: c[i][m] multiplies "
        "(x - x[i])^(k - m)",
    ),
    F("left0", "double", "value for x <= x[0]"),
    F("left1", "double", "first derivative for x <= x[0]"),
    F("left2", "double", "second derivative for x <= x[0]"),
    F("right0", "double", "value for x >= x[n]"),
    F("right1", "double", "first derivative for x >= x[n]"),
    F("right2", "double", "second derivative for x >= x[n]"),
]

SETUP_FIELDS = [
    # sizes and switches
    F("method", "int", "0 localized-dynamic, 1 coupled-dynamic, 2 coupled-classic"),
    F("moving_load", "int", "1: prescribed axle forces, no vehicle DOFs"),
    F("cars", "int", "number of cars"),
    F("nw", "int", "wheels (axles) per car"),
    F("nc", "int", "contacts = cars * nw"),
    F("spans", "int", "number of spans"),
    F("elements", "int", "elements per span"),
    F("nd", "int", "DOFs per span, 3 (elements + 1)"),
    F("ns", "int", "support constraints per span"),
    F("nfree", "int", "DOFs per span that are not support DOFs"),
    F("band_p", "int", "half bandwidth of the span matrices"),
    F("band_pf", "int", "half bandwidth of K^ restricted to the free DOFs"),
    F("bw_max", "int", "largest interface half bandwidth the workspace holds"),
    F("bw_car", "int", "largest index distance between two wheels of one car in the track order"),
    F("output_every", "int", "record every Nth step"),
    F("mid_first", "int", "first span DOF of the midspan element"),
    F("carbody_z", "int", "vehicle DOF of the car-body bounce (-1: none)"),
    F("carbody_theta", "int", "vehicle DOF of the car-body pitch (-1: none)"),
    F("creep", "int", "1: explicit creep forces (svbi.runtime.model.wheel_creep)"),
    F("creep_ground", "int", "1: off the bridge the wheels creep against the moving ground"),
    F(
        "unilateral",
        "int",
        "1: localized-dynamic with the per-wheel active set: free wheels carry P = 0, a lift-off or "
        "landing stops the loop with STATUS_EVENT",
    ),
    F("mb_num_n", "int", "coefficients of the numerator of Eq. (31) in xi"),
    F("mb_den_n", "int", "coefficients of the denominator of Eq. (31) in xi"),
    F("steps", "long", "steps of the whole run"),
    # scalars
    F("dt", "double", "time step (s)"),
    F("a0", "double", "Newmark 4/dt^2"),
    F("a1", "double", "Newmark 2/dt"),
    F("a2", "double", "Newmark 4/dt"),
    F("gravity", "double", "g (m/s^2)"),
    F("speed", "double", "train speed (m/s)"),
    F("start", "double", "leading axle at t = 0 (m)"),
    F("span_length", "double", "L (m)"),
    F("inv_span_length", "double", "1 / L"),
    F("inv_element_length", "double", "1 / le"),
    F("acceleration", "double", "train acceleration (m/s^2; 0: constant speed, rows from S->rows)"),
    F("stop_time", "double", "when a braking train stands (s; 1e300: never)"),
    F("creep_min_speed", "double", "no creep force below this speed (m/s; a train whose speed changes)"),
    F("p_P", "double", "point row: coefficient of P[y]"),
    F("p_Q", "double", "point row: coefficient of Q[y]"),
    F("p_q2", "double", "point row: coefficient of q''"),
    F("p_q1", "double", "point row: coefficient of q'"),
    F("p_q", "double", "point row: coefficient of q"),
    F("d", "double", "a0 + 2 zeta omega a1 + omega^2"),
    F("c2", "double", "2 zeta omega"),
    F("w2", "double", "omega^2"),
    F("force_limit", "double", "|contact force| that stops the run (N)"),
    F("gap_limit", "double", "|gap| that stops the run (m)"),
    F("sC", "double", "coupled-classic: scale of the contact rows and columns"),
    # contacts
    F("order", "int*", "nc: contact indices in track order (front to back)"),
    F("offsets", "double*", "nc: distance of every contact behind the leading axle (m)"),
    F("axle_loads", "double*", "nc: moving-load axle forces (N)"),
    F("rows", "double*", "(ROW_DEG + 1) x ROW_COLS: contact-row polynomial coefficients in xi"),
    F(
        "rows_va",
        "double*",
        "4 x (ROW_DEG + 1) x ROW_COLS: the rows of a changing speed, T0 + v T1 + v^2 T2 + a Ta",
    ),
    F("mb_num", "double*", "mb_num_n coefficients (ascending powers of xi) of Eq. (31)'s numerator"),
    F("mb_den", "double*", "mb_den_n coefficients of Eq. (31)'s denominator"),
    # one span
    F("sup", "int*", "ns: span DOF of every support constraint"),
    F("sup_vertical", "int*", "ns: 1 for a vertical support, 0 for the longitudinal one"),
    F("sup_x", "double*", "ns: position of every support in its span (0 or L)"),
    F("free", "int*", "nfree: span DOFs that are not support DOFs"),
    F("C_ptr", "int*", "nd + 1: CSR row pointers of the span damping matrix"),
    F("C_idx", "int*", "CSR column indices"),
    F("C_val", "double*", "CSR values"),
    F("MC_ptr", "int*", "nd + 1: CSR row pointers of the union pattern of M and C"),
    F("MC_idx", "int*", "its column indices"),
    F("MC_m", "double*", "M on that pattern"),
    F("MC_c", "double*", "C on that pattern"),
    F("CT", "double*", "nd x ns: C T, damping of the quasi-static support motion"),
    F("react_rows", "double*", "3 x ns x nd: rows of M, C and K at the support DOFs (support reactions)"),
    F("Khat_band", "double*", "nd x (band_p + 1): lower band of K^ = K + a1 C + a0 M"),
    F("Khat_ff_band", "double*", "nfree x (band_pf + 1): lower band of K^ on the free DOFs"),
    F("Khat_fs", "double*", "nfree x ns: K^ coupling free DOFs to support DOFs"),
    F("S", "double*", "nd x nd: bridge compliance with the supports held"),
    F("mid_w", "double*", "6: vertical shape row at midspan"),
    F("mid_u", "double*", "6: axial shape row at midspan"),
    F("mG", "double*", "ns: support constraint masses, Eq. (34)"),
    F("sG", "double*", "ns: coupled-classic scale of the support rows"),
    # one car
    F("VW_ptr", "int*", "NW + 1: W by columns"),
    F("VW_idx", "int*", "row indices"),
    F("VW_val", "double*", "values"),
    F("V_kinv", "double*", "NV x NV: inverse of the vehicle effective matrix"),
    F("V_khat", "double*", "NV x NV: vehicle effective matrix K + a1 C + a0 M"),
    F("V_K", "double*", "NV x NV: vehicle stiffness"),
    F("V_M", "double*", "NV x NV: vehicle mass in the equations of motion (active or full)"),
    F("V_C", "double*", "NV x NV: vehicle damping"),
    F("V_F", "double*", "NV: constant vehicle load (gravity less the static spring forces)"),
    F("V_W", "double*", "NV x NW: contact directions W_N^V"),
    F("V_A", "double*", "NV x NW: K^-1 W"),
    F("V_B", "double*", "NW x NW: (F_V + diag c_g)^-1"),
    F("V_Fstar", "double*", "NW x NW: full-vehicle wheel flexibility"),
    F("c_g", "double*", "NW: aux-point compliance 1 / (a0 m_g)"),
    F("m_g", "double*", "NW: aux-point masses"),
    F("mV", "double*", "NW: wheel-aux constraint masses, Eq. (27)"),
    F("VT_ptr", "int*", "NW + 1: W_T^V by columns (wheel spin), exact zeros dropped"),
    F("VT_idx", "int*", "row indices"),
    F("VT_val", "double*", "values"),
    F("creep_rolling", "int*", "NW: 1 for a wheel that rolls (a spin DOF) and creeps"),
    F("creep_params", "double*", "NW x 8: creep-law parameters of every wheel (creep_force kernel)"),
    # the plastic impact of landing wheels (localized-dynamic, unilateral; impact.c)
    F("I_MinvW", "double*", "NV x NW: M^-1 W of one car (full mass: the aux point rides its wheel)"),
    F("I_MinvC", "double*", "NV x NV: M^-1 C"),
    F("I_GV", "double*", "NW x NW: W^T M^-1 W"),
    F("I_SM", "double*", "nd x nd (nkind x nd x nd when general): mass compliance, supports held"),
    F(
        "I_shapes",
        "double*",
        "row tables (one per element length) x 2 x (ROW_DEG + 1) x 6: N1 and N2 (dN0/dx, d2N0/dx2) in xi",
    ),
    F("I_lk_col_a", "double*", "general: nlinks x nd, the column of S_M at end a (0 for a spring)"),
    F("I_lk_col_b", "double*", "general: nlinks x nd, the column of S_M at end b (0 for a spring)"),
    F("I_lk_A", "double*", "general: nlinks x (band_links + 1), lower band of L S_M L^T (1 for a spring)"),
    # a bridge of substructures (localized-dynamic; substructures.c,
    # docs/c-backend.md "Bridges of substructures")
    F(
        "general",
        "int",
        "1: spans and pier columns of several kinds joined by links (continuous girders, unequal "
        "spans, piers, bearings): the g_* fields replace the one-span fields above",
    ),
    F("nsub", "int", "substructures: the spans, then the pier columns"),
    F("nkind", "int", "substructure kinds (one set of matrices each)"),
    F("nlinks", "int", "links between substructures (continuity, bearings)"),
    F("nact", "int", "active support constraints (the results' support dimension)"),
    F("nrclass", "int", "contact-row tables (one per span element length)"),
    F("band_links", "int", "half bandwidth of the link matrix A = L S L^T + diag(1/k) in link order"),
    F("g_kind", "int*", "nsub: kind of every substructure"),
    F("g_line_x", "double*", "spans + 1: position of every support line (m)"),
    F("g_inv_el", "double*", "spans: 1 / element length of every span"),
    F("g_rclass", "int*", "spans: which contact-row table of rows (rows_va) serves every span"),
    F(
        "g_S",
        "double*",
        "nkind x nd x nd: compliance with the supports held, per kind (interface, correction)",
    ),
    F("g_nfree", "int*", "nkind: DOFs of the kind that no support holds"),
    F("g_free", "int*", "nkind x nd: those DOFs (the first g_nfree), in band order"),
    F("g_pf", "int*", "nkind: half bandwidth of K^ on them"),
    F("g_kff_ptr", "int*", "nkind + 1: where each kind's band starts in g_kff"),
    F("g_kff", "double*", "the lower bands of K^ = K + a1 C + a0 M on the free DOFs, kind after kind"),
    F("g_kfs", "double*", "nkind x nd x 3: K^ between the free DOFs and the support slots (0: no support)"),
    F("g_mck_ptr", "int*", "nkind x (nd + 1): absolute CSR row pointers of the union pattern of M, C, K"),
    F("g_mck_idx", "int*", "its column indices"),
    F("g_m", "double*", "M on that pattern"),
    F("g_c", "double*", "C on that pattern"),
    F("g_k", "double*", "K on that pattern"),
    F("g_ct_ptr", "int*", "nsub * nd + 1: CSR of C T (the quasi-static field of the linked bridge)"),
    F("g_ct_idx", "int*", "its columns: active supports"),
    F("g_ct_val", "double*", "its values"),
    F("g_slot_dof", "int*", "nsub x 3: DOF of every support slot"),
    F("g_slot_active", "int*", "nsub x 3: 1 where the slot holds its DOF on the ground"),
    F("g_slot_comp", "int*", "nsub x 3: 0 longitudinal, 1 vertical, 2 rotation (a pier base: no ground)"),
    F("g_slot_x", "double*", "nsub x 3: position of every support slot (m)"),
    F("g_act_slot", "int*", "nact: slot of every active support, in the results' order"),
    F("g_rx_ptr", "int*", "nact + 1: the substructure DOFs merged with each active support (reactions)"),
    F("g_rx_sub", "int*", "their substructures"),
    F("g_rx_dof", "int*", "their DOFs"),
    F("g_lk_a_sub", "int*", "nlinks: substructure of end a (links in track order, front to back)"),
    F("g_lk_a_dof", "int*", "nlinks: DOF of end a"),
    F("g_lk_b_sub", "int*", "nlinks: substructure of end b"),
    F("g_lk_b_dof", "int*", "nlinks: DOF of end b"),
    F("g_lk_spring", "int*", "nlinks: 1 for a bearing spring (its gap follows no constraint row)"),
    F("g_lk_x", "double*", "nlinks: position of every link (non-increasing)"),
    F("g_lk_col_a", "double*", "nlinks x nd: the column of S of end a's DOF"),
    F("g_lk_col_b", "double*", "nlinks x nd: the column of S of end b's DOF"),
    F("g_lk_A", "double*", "nlinks x (band_links + 1): lower band of A"),
    F("g_sl_ptr", "int*", "nsub + 1: the links touching every substructure"),
    F("g_sl_link", "int*", "the link"),
    F("g_mid_w", "double*", "spans x 6: vertical shape row at every span's midspan"),
]

STATE_FIELDS = [
    F("t", "double", "time of the state (s)"),
    F("uV", "mdouble*", "cars x NV"),
    F("vV", "mdouble*", "cars x NV"),
    F("aV", "mdouble*", "cars x NV"),
    F("uB", "mdouble*", "spans x nd"),
    F("vB", "mdouble*", "spans x nd"),
    F("aB", "mdouble*", "spans x nd"),
    F("ug", "mdouble*", "nc: aux points"),
    F("vg", "mdouble*", "nc"),
    F("ag", "mdouble*", "nc"),
    F("P", "mdouble*", "nc: wheel-rail force, compression positive"),
    F("PV", "mdouble*", "nc: wheel-aux force"),
    F("lamV", "mdouble*", "3 x nc: coupled-dynamic multipliers of the wheel-aux constraints and rates"),
    F("lamB", "mdouble*", "3 x nc: aux-bridge multipliers"),
    F("lamG", "mdouble*", "3 x spans * ns: support multipliers"),
    F("creepage", "mdouble*", "nc: creepage at t"),
    F("creep_force", "mdouble*", "nc: creep force on the wheel at t (it loads the next step)"),
    F("in_contact", "mchar*", "nc: 1 wheel on its rail, 0 airborne (unilateral runs)"),
]

EXCITATION_FIELDS = [
    F("irr_mode", "int", "rail irregularity: 0 none, 1 table, 2 stream"),
    F("irr_ramp", "int", "1: the table is multiplied by the onset ramp table"),
    F("irr_start", "double", "r = 0 for x <= irr_start"),
    F("irr_base", "ppoly", "profile"),
    F("irr_onset", "ppoly", "onset ramp"),
    F(
        "gv_mode",
        "int",
        "vertical ground: 0 at rest, 1 synchronous table, 2 travelling table, 3 stream, "
        "4 one table per support line",
    ),
    F("gh_mode", "int", "longitudinal ground: same codes"),
    F("gv", "ppoly", "vertical q(t)"),
    F("gh", "ppoly", "longitudinal q(t)"),
    F("gv_lines", "ppoly*", "spans + 1 vertical tables, one per support line (mode 4)"),
    F("gh_lines", "ppoly*", "spans + 1 longitudinal tables (mode 4)"),
    F("mids", "double*", "spans: midpoints between support lines; a point takes the nearest line"),
    F("apparent_velocity", "double", "wave-passage apparent velocity (m/s)"),
    F("x_ref", "double", "where the wave passes at the arrival time (m)"),
    F("ground_per_support", "int", "1: ground_uz, ground_ux are recorded per support"),
    F("s_n0", "long", "streams: step index n of the first stream entry (t = (n + 1) dt)"),
    F("s_count", "long", "streams: entries held"),
    F("s_rail", "double*", "s_count x 3 x nc: r, r', r'' under every contact"),
    F(
        "s_under",
        "double*",
        "s_count x 4 x nc: q, q', q'' of the ground under every contact, and the longitudinal q'",
    ),
    F("s_sup", "double*", "s_count x 3 x (spans * ns): support targets q, q', q''"),
    F("s_rec", "double*", "s_count x 2 x nrec: recorded ground_uz, ground_ux"),
]

OUTPUT_FIELDS = [
    F("row", "long", "next output row (in/out)"),
    F("nout", "long", "rows available"),
    F("time", "mdouble*", "nout"),
    F("midspan_uz", "mdouble*", "nout x spans"),
    F("midspan_ux", "mdouble*", "nout x spans"),
    F("deck_acceleration", "mdouble*", "nout x spans: vertical acceleration at midspan"),
    F("end_rotation", "mdouble*", "nout x spans x 2: rotation of the left and right end nodes"),
    F("pier_top_ux", "mdouble*", "nout x piers: longitudinal displacement of every pier top (general)"),
    F("ground_uz", "mdouble*", "nout (x spans * ns when per support)"),
    F("ground_ux", "mdouble*", "nout (x spans * ns when per support)"),
    F("contact_force", "mdouble*", "nout x nc"),
    F("creep_force", "mdouble*", "nout x nc"),
    F("creepage", "mdouble*", "nout x nc"),
    F("irregularity", "mdouble*", "nout x nc"),
    F("carbody_uz", "mdouble*", "nout x cars"),
    F("carbody_az", "mdouble*", "nout x cars"),
    F("carbody_pitch", "mdouble*", "nout x cars"),
    F("vehicle_u", "mdouble*", "nout x cars x NV: every vehicle DOF (results body_uz, body_pitch)"),
    F("vehicle_a", "mdouble*", "nout x cars x NV: every vehicle acceleration (results body_az)"),
    F("gap_vehicle", "mdouble*", "nout x nc"),
    F("gap_bridge", "mdouble*", "nout x nc"),
    F("gap_support", "mdouble*", "nout x spans * ns"),
    F("support_reaction", "mdouble*", "nout x spans * ns: support forces beyond the dead load"),
    F("forces", "mdouble*", "(steps + 1) x nc: contact force at every step"),
    F("contact_state", "mchar*", "nout x nc: 1 on the rail, 0 airborne (unilateral runs)"),
    F("wheel_uplift", "mdouble*", "nout x nc: height of an airborne wheel above the rail (unilateral)"),
    F("contact_steps", "mchar*", "(steps + 1) x nc: the contact state at every step (unilateral)"),
]

INFO_FIELDS = [
    F("status", "int", "0 ok, else an error code (see the header)"),
    F(
        "quantity",
        "int",
        "what failed: 1 contact force, 2 bridge, 3 vehicle; gaps: 1 support, 2 vehicle, 3 bridge",
    ),
    F("step", "long", "n of the step that failed (t = (n + 1) dt)"),
    F("steps_done", "long", "last step index whose state is complete (n + 1)"),
    F("value", "double", "the offending value"),
]

STRUCTS = {
    "ppoly": PPOLY_FIELDS,
    "setup": SETUP_FIELDS,
    "state": STATE_FIELDS,
    "excitation": EXCITATION_FIELDS,
    "outputs": OUTPUT_FIELDS,
    "info": INFO_FIELDS,
}


# --------------------------------------------------------------------------------------------------
# the glue's files


ROW_TABLES = ("N0", "W_hat", "c_P_ue", "c_Q_ue", "T0", "T1", "c_scalars")
"""Generated tables (``svbi.runtime.model.contact_rows``; ``nonzero_columns`` of the bridge module's
plain data) of the ``ROW_BLOCKS`` and ``ROW_SCALARS`` columns, in column order."""

CREEP_MODEL = "creep_split"
"""Model name of the two generated creep functions linked into the loop
(``svbi.codegen.creep.split_creep_force``, rendered by :mod:`svbi.codegen.loop_glue`)."""

TYPES_HEADER = "svbi_solver_types.h"
ROWS_HEADER = "svbi_contact_rows.h"
TOPOLOGY_HEADER = "svbi_topology.h"
SOLVER_FOLDER = "solver"
"""``generated/solver/``: the glue that depends on neither the topology nor the bridge element."""
BRIDGE_FOLDER = "frame2d"
"""``generated/frame2d/``: the glue of the bridge element (contact rows, the split creep law)."""
MOVING_LOAD_FOLDER = "moving-load"
CREEP_FILES = ("creep_split_kernels.c", "creep_split_kernels.h", "creep_split.h", "creep_split_model.c")
GLUE_NAMES = frozenset({TYPES_HEADER, ROWS_HEADER, TOPOLOGY_HEADER, *CREEP_FILES})
"""File names of the loop's glue inside generated model folders (not part of a kernels-only export)."""
