"""The C loop's files in layers: no call circle between files, and no call upwards.

``runtime/csrc/`` holds the loop in four folders, bottom to top ``core``, ``step``, ``methods``,
``loop`` (``svbi.runtime.backends.c.build.CSRC_LAYERS``, docs/c-backend.md). A file may use what
the files of its own layer and of the layers below define; the file-level graph of those uses has
no circle.

The graph is built from the sources themselves: comments, strings and preprocessor lines removed,
every definition at file level found (functions; objects with an initializer, such as a table of
function pointers), and every identifier in a definition's body that names what another file
defines is an edge between the two files. A ``static`` function of a ``.c`` file is that file's
own (another file's function of the same name is another function); what a header defines is
visible to every file that includes it. Declarations (prototypes, ``extern``) are not uses, and a
call through a function pointer is no edge: the table holding the pointer is, where it is filled.
The detector is tested on planted sources first.
"""

from __future__ import annotations

import re
from importlib import resources

from test_architecture import cycles

from svbi.runtime.backends.c import build as c_solver_build

KEYWORDS = frozenset({"if", "for", "while", "switch", "return", "sizeof", "do", "else"})
IDENT = re.compile(r"\b([A-Za-z_]\w*)\b")


def strip_c(text: str) -> str:
    """The source without comments, string and character literals, and preprocessor lines (line
    breaks kept)."""
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)
    text = re.sub(r"'(?:\\.|[^'\\\n])*'", "''", text)
    return re.sub(r"^[ \t]*#[^\n]*(?:\\\n[^\n]*)*", "", text, flags=re.M)


def definitions(text: str) -> list[tuple[str, bool, str]]:
    """``(name, static, body)`` of every definition at file level of a stripped source: functions
    (``head(...) { body }``) and initialised objects (``head name = { ... };`` or ``= expr;``)."""
    out = []
    depth, start, i, n = 0, 0, 0, len(text)
    while i < n:
        c = text[i]
        if c in "{(":
            depth += 1
        elif c in "})":
            depth -= 1
        elif c == ";" and depth == 0:
            head = text[start:i]
            if "=" in head:  # an object with a scalar initializer
                decl, _, init = head.partition("=")
                m = re.search(r"([A-Za-z_]\w*)\s*(?:\[[^\]]*\]\s*)*$", decl)
                if m:
                    out.append((m.group(1), bool(re.search(r"\bstatic\b", decl)), init))
            start = i + 1
        if c == "{" and depth == 1:
            head = text[start:i]
            j, d = i, 0
            while True:
                if text[j] == "{":
                    d += 1
                elif text[j] == "}":
                    d -= 1
                    if d == 0:
                        break
                j += 1
            body = text[i : j + 1]
            function = re.search(r"([A-Za-z_]\w*)\s*\(([^;{}]*)\)\s*$", head)
            initialised = re.search(r"([A-Za-z_]\w*)\s*(?:\[[^\]]*\]\s*)*=\s*$", head)
            static = bool(re.search(r"\bstatic\b", head))
            if function and function.group(1) not in KEYWORDS:
                out.append((function.group(1), static, body))
                i, start, depth = j + 1, j + 1, 0
                continue
            if initialised:
                out.append((initialised.group(1), static, body))
                # the initializer's statement ends at its ';'
                i, depth = j + 1, 0
                continue
            # struct, union or enum bodies: declarations, skipped with their statement
            i, depth = j + 1, 0
            continue
        i += 1
    return out


def file_graph(files: dict[str, str]) -> dict[str, dict[str, set[str]]]:
    """``{file: {file it uses: names}}`` of C sources ``{name: text}`` (see the module docstring)."""
    own: dict[str, dict[str, str]] = {}
    visible: dict[str, list[str]] = {}
    for name, text in files.items():
        defs = definitions(strip_c(text))
        own[name] = {d: body for d, _, body in defs}
        for d, static, _ in defs:
            if name.endswith(".h") or not static:
                visible.setdefault(d, []).append(name)
    edges: dict[str, dict[str, set[str]]] = {}
    for name, defs in own.items():
        for body in defs.values():
            for ident in set(IDENT.findall(body)):
                if ident in defs:
                    continue
                for other in visible.get(ident, ()):
                    if other != name:
                        edges.setdefault(name, {}).setdefault(other, set()).add(ident)
    return edges


def circles(edges: dict[str, dict[str, set[str]]]) -> list[list[str]]:
    """The strongly connected components of more than one file (each holds a call circle): the
    same search as the Python modules' (``test_architecture.cycles``)."""
    nodes = set(edges) | {g for d in edges.values() for g in d}
    return cycles({v: set(edges.get(v, {})) for v in nodes})


def upward(edges: dict[str, dict[str, set[str]]], layer: dict[str, int]) -> list[str]:
    """Uses of a file of a higher layer."""
    return [
        f"{a} ({layer[a]}) -> {b} ({layer[b]}): {sorted(names)}"
        for a, targets in sorted(edges.items())
        for b, names in sorted(targets.items())
        if layer[b] > layer[a]
    ]


def layered_sources() -> tuple[dict[str, str], dict[str, int]]:
    """The static sources ``{file name: text}`` and each file's layer (0 = core)."""
    folder = resources.files("svbi.runtime").joinpath(c_solver_build.CSRC)
    files, layer = {}, {}
    for k, name in enumerate(c_solver_build.CSRC_LAYERS):
        for p in folder.joinpath(name).iterdir():
            if p.name.endswith((".c", ".h")):
                files[p.name] = p.read_text()
                layer[p.name] = k
    return files, layer


# ------------------------------------------------------------------------------------------------
# the detector on planted sources

PLANTED = {
    "a.h": "static inline int a_twice(int x) { return 2 * x; } /* b_call(x) in a comment */\n"
    "int b_call(int x);\n",
    "a.c": '#include "a.h"\nint a_call(int x) { return a_twice(x) + 1; }\n',
    "b.c": "static int helper(int x) { return x; }\nint b_call(int x) { return helper(a_call(x)); }\n",
    "c.c": "static int a_call(int x) { return x; } /* its own */\n"
    'int c_call(int x) { const char* s = "b_call("; (void)s; return a_call(x) + b_call(x); }\n',
    "t.c": "typedef struct { int (*f)(int); } table_t;\nconst table_t table = {c_call};\n"
    "static const int size = sizeof(table_t);\nint t_call(void) { return table.f(size); }\n",
}


def test_detector_reads_definitions_and_uses():
    edges = file_graph(PLANTED)
    assert edges == {
        "a.c": {"a.h": {"a_twice"}},
        "b.c": {"a.c": {"a_call"}},
        "c.c": {"b.c": {"b_call"}},  # its own static a_call; the string is no call
        "t.c": {"c.c": {"c_call"}},  # the table's initializer refers to c_call
    }
    assert circles(edges) == []


def test_detector_finds_a_planted_circle():
    files = dict(PLANTED)
    files["a.c"] = '#include "a.h"\nint a_call(int x) { return a_twice(x) + t_call(); }\n'
    found = circles(file_graph(files))
    assert found == [["a.c", "b.c", "c.c", "t.c"]]
    two = {
        "x.c": "int x(void) { return y(); }\n",
        "y.c": "int y(void) { return 0; }\nint z(void) { return x(); }\n",
    }
    assert circles(file_graph(two)) == [["x.c", "y.c"]]


def test_detector_finds_an_upward_use():
    edges = file_graph(PLANTED)
    layer = {"a.h": 0, "a.c": 0, "b.c": 1, "c.c": 1, "t.c": 0}
    assert upward(edges, layer) == ["t.c (0) -> c.c (1): ['c_call']"]


# ------------------------------------------------------------------------------------------------
# the loop's sources


def test_sources_are_in_the_layers():
    folder = resources.files("svbi.runtime").joinpath(c_solver_build.CSRC)
    loose = sorted(p.name for p in folder.iterdir() if p.name.endswith((".c", ".h")))
    assert loose == []
    folders = sorted(p.name for p in folder.iterdir() if p.is_dir() and not p.name.startswith(("_", ".")))
    assert folders == sorted((*c_solver_build.CSRC_LAYERS, c_solver_build.CSRC_3D))
    files, _ = layered_sources()
    assert set(files) == set(c_solver_build.static_sources())


def test_graph_of_the_loop_is_read():
    """The parser sees the loop's structure (a detector that reads nothing would pass the rest)."""
    files, _ = layered_sources()
    edges = file_graph(files)
    assert "svbi_step_localized" in edges["solver.c"]["localized.c"]
    assert "svbi_place" in edges["substructures.c"]["contacts.c"]
    assert "svbi_gb_factor_solve_r" in edges["interface.c"]["band.c"]
    assert "svbi_nm_vel" in edges["bridge.c"]["newmark.h"]
    assert sum(len(t) for t in edges.values()) > 30


def test_no_call_circle_between_files():
    files, _ = layered_sources()
    assert circles(file_graph(files)) == []


def test_no_use_of_a_higher_layer():
    files, layer = layered_sources()
    assert upward(file_graph(files), layer) == []


def newmark_lines(files: dict[str, str]) -> list[str]:
    """Lines outside newmark.h that write one of Newmark's relations, ``a0 u - P``, ``a1 u + v``,
    ``a2 v + a``, ... (a product by a0, a1 or a2 then a sum; an effective mass a0 m is none)."""
    operand = r"(?:\w+(?:->|\.))*\w+(?:\[[^\]]*\])?"
    pattern = re.compile(r"\ba[012] \*\s*" + operand + r"\s+[-+]\s")
    return [
        f"{name}: {line.strip()}"
        for name, text in files.items()
        if name != "newmark.h"
        for line in strip_c(text).splitlines()
        if pattern.search(line)
    ]


def test_detector_finds_newmark_relations():
    planted = {
        "p.c": "void f(void) {\n  v[i] = S->a1 * w->bu[i] - w->QB[i];\n  P = a0 * u[d] + a2 * v + a;\n"
        "  A = S->a0 * S->m_g[i];\n  pt = (Pg - g) / S->a0;\n}\n",
        "newmark.h": "static inline double f(double u, double P) { return a0 * u - P; }\n",
    }
    assert newmark_lines(planted) == [
        "p.c: v[i] = S->a1 * w->bu[i] - w->QB[i];",
        "p.c: P = a0 * u[d] + a2 * v + a;",
    ]


def test_newmark_relations_have_one_home():
    """Newmark's relations are written in newmark.h only."""
    files, _ = layered_sources()
    assert newmark_lines(files) == []


# ------------------------------------------------------------------------------------------------
# the workspace's parts: each used only by the files its type names

CARVER = "solver.c"
"""The file that carves the workspace and fills it at set-up: it touches every part."""


def work_parts(header: str) -> dict[str, tuple[str, set[str]]]:
    """``{member: (type, users)}`` of ``work_t``'s parts in ``internal.h``: every part is a
    ``typedef struct { ... } NAME;`` whose comment names its users (``used by: a.c b.c``)."""
    users: dict[str, set[str]] = {}
    for comment, name in re.findall(
        r"/\*((?:(?!\*/).)*?used by:(?:(?!\*/).)*)\*/\s*typedef struct \{.*?\}\s*(\w+);", header, re.S
    ):
        listed = comment.split("used by:", 1)[1].replace("*", " ")
        users[name] = set(listed.split())
    body = re.search(r"typedef struct \{([^}]*)\}\s*work_t;", header, re.S)
    assert body, "work_t not found"
    members = re.findall(r"(\w+)\s+(\w+)\s*;", strip_c(body.group(1)))
    return {member: (kind, users.get(kind, set())) for kind, member in members if kind in users}


def part_uses(files: dict[str, str], parts: dict[str, tuple[str, set[str]]]) -> dict[str, set[str]]:
    """``{part member: files that use it}``: ``w->part.`` or ``w.part.`` in a stripped source."""
    uses: dict[str, set[str]] = {m: set() for m in parts}
    for name, text in files.items():
        for member in re.findall(r"\bw\s*(?:->|\.)\s*(\w+)\s*\.", strip_c(text)):
            if member in uses:
                uses[member].add(name)
    return uses


def misplaced(files: dict[str, str], header: str) -> list[str]:
    """Uses of a part by a file its type does not name (the carver aside), and files named that do
    not use it."""
    parts = work_parts(header)
    out = []
    for member, found in sorted(part_uses(files, parts).items()):
        kind, users = parts[member]
        out += [f"{f} uses {member} ({kind})" for f in sorted(found - users - {CARVER})]
        out += [f"{f} is named by {kind} but uses none of it" for f in sorted(users - found)]
    return out


PLANTED_HEADER = """
/* What a contact is.
 * used by: a.c b.c */
typedef struct { double* x; } contact_t;
/* The bridge.
 * used by: b.c */
typedef struct { double* u; int blocked; } bridge_t;
typedef struct { const void* kind; contact_t ct; bridge_t br; } work_t;
"""


def test_part_check_finds_a_planted_misuse():
    files = {
        "a.c": "void f(work_t* w) { w->ct.x[0] = 1.0; /* w->br.u in a comment */ }\n",
        "b.c": "void g(work_t* w) { w->ct.x[0] = w->br.u[0]; }\n",
        CARVER: "void carve(work_t w) { w.ct.x = 0; w.br.u = 0; }\n",
    }
    parts = work_parts(PLANTED_HEADER)
    assert parts == {"ct": ("contact_t", {"a.c", "b.c"}), "br": ("bridge_t", {"b.c"})}
    assert misplaced(files, PLANTED_HEADER) == []
    files["a.c"] = "void f(work_t* w) { w->ct.x[0] = w -> br.blocked; }\n"
    assert misplaced(files, PLANTED_HEADER) == ["a.c uses br (bridge_t)"]
    files["b.c"] = "void g(work_t* w) { w->br.u[0] = 0.0; }\n"
    assert misplaced(files, PLANTED_HEADER) == [
        "a.c uses br (bridge_t)",
        "b.c is named by contact_t but uses none of it",
    ]


def test_every_part_of_the_workspace_is_used_only_by_the_files_it_names():
    files, _ = layered_sources()
    header = files["internal.h"]
    parts = work_parts(header)
    assert len(parts) >= 8, parts  # the parts are found (contacts, bridge, interface, ...)
    body = re.search(r"typedef struct \{([^}]*)\}\s*work_t;", header, re.S)
    assert body
    members = re.findall(r"(\w+)\s*;", strip_c(body.group(1)))
    assert set(members) == {"kind", *parts}, members  # nothing but the kind's table and the parts
    assert misplaced(files, header) == []
