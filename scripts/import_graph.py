#!/usr/bin/env python3
"""Import cycles in the workspace's library crates, file by file and folder by folder.

Each crate's library (the .rs files under `<crate>/src`, `src/bin/` excepted: a binary is a crate of
its own that uses the library by name) is drawn as a graph whose nodes are files and whose arrows
are imports. An arrow A -> B means "code in file A names an item that file B defines":

  * every path of a plain `use` (grouped `use a::{b, c::{d}}`, `as` renames, `self`, globs) and
    every qualified path in code (`crate::x::f()`, `super::Y::new()`, `child::g()`, `alias::h()`
    where `alias` is a module brought in by `use`) that stays inside the crate: it starts with
    `crate`, `super` or `self`, names a child module (2018 relative paths) or a module alias;
  * resolved to the file that DEFINES the item: the module path is walked as far as it names
    module files, and the next segment, when not defined at the top of that file (`fn`, `struct`,
    `enum`, `trait`, `type`, `const`, `static`, `union`, `macro_rules!`, inline `mod NAME {`), is
    followed through the `use` declarations of that file (`pub use child::Item`, renames, globs),
    recursively; a path that ends at a module, or an item the resolver cannot find, points to the
    module's own file (`foo.rs` or `foo/mod.rs`);
  * a re-export (`pub use`, `pub(crate) use`, ...) is an arrow only when the re-exporting file's
    own code uses the name as well; one that only passes an item through is not (the files that
    import it get the arrow to the defining file instead);
  * NOT arrows: `mod child;` declarations, external crates, self-arrows, and test code (`#[cfg(test)]`
    items and file modules, and every `mod tests { ... }` block: tests may import anything).

Comments (doc comments and intra-doc links included) and string/char literals are blanked first.
Definitions are recognised at column 0 only (rustfmt layout), so methods inside `impl` blocks and
items of inline modules do not count as the file's items.

A cycle is a strongly connected component of more than one node, reported
  (a) among files, and
  (b) among folders: each file collapsed to its top-level module under src/ (src/train/step.rs ->
      `train`, src/config.rs -> `config`, src/lib.rs -> `lib.rs`), an arrow between two of them
      standing for every file arrow from one to the other.
Every arrow of a cycle is printed with the lines that make it (file:line and the path written).
Cycles are arrows running back up; the goal is none. Exit status 1 when any cycle is found.

Usage: scripts/import_graph.py [--crate starnet-data ...] [--dot] [--self-test]
"""
import argparse
import bisect
import os
import re
import sys
import unittest
from collections import defaultdict

MAX_DEPTH = 12  # re-export hops followed before giving up
MAX_CHAINS = 12  # elementary cycles listed per component
IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
ITEM_RE = re.compile(
    r"^(?:pub(?:\s*\([^)]*\))?\s+)?(?:(?:const|async|unsafe|default|extern(?:\s+\"\s*\")?)\s+)*"
    r"(?:(?:fn|struct|enum|trait|type|const|union|static(?:\s+mut)?)\s+(" + IDENT + r")"
    r"|macro_rules!\s*(" + IDENT + r")|mod\s+(" + IDENT + r")\s*\{)",
    re.M,
)
USE_RE = re.compile(r"(?<![\w$])(pub\s*(?:\([^)]*\))?\s*)?use\s")
INLINE_RE = re.compile(r"(?<![\w:$])((?:\$crate|" + IDENT + r")(?:::" + IDENT + r")+)")
TOKEN_RE = re.compile(r"::|\$crate|" + IDENT + r"|\S")
CFG_TEST_RE = re.compile(r"#\[cfg\(\s*test\s*\)\]")
TESTS_MOD_RE = re.compile(r"(?<![\w])mod\s+tests\s*\{")
MOD_DECL_RE = re.compile(r"^\s*(?:pub(?:\s*\([^)]*\))?\s+)?mod\s+(" + IDENT + r")\s*;")


# ----------------------------------------------------------------------------- lexing


def blank(text, start, end):
    """`text` with [start, end) turned into spaces, newlines kept (line numbers stay right)."""
    return text[:start] + re.sub(r"[^\n]", " ", text[start:end]) + text[end:]


def literal_end(src, i):
    """End of the comment or literal starting at `src[i]`, or None when none starts there."""
    if src.startswith("//", i):
        end = src.find("\n", i)
        return len(src) if end < 0 else end
    if src.startswith("/*", i):
        return block_comment_end(src, i)
    raw = re.match(r"b?r(#*)\"", src[i:]) if src[i] in "br" and not is_ident_char(src, i - 1) else None
    if raw:
        end = src.find('"' + raw.group(1), i + raw.end())
        return len(src) if end < 0 else end + 1 + len(raw.group(1))
    if src[i] == '"':
        return quoted_end(src, i + 1, '"')
    if src[i] == "'":
        if src.startswith("\\", i + 1):
            return quoted_end(src, i + 1, "'")
        if src.startswith("'", i + 2):
            return i + 3
    return None


def is_ident_char(src, i):
    return i >= 0 and (src[i].isalnum() or src[i] == "_")


def block_comment_end(src, i):
    depth, j = 0, i
    while j < len(src):
        if src.startswith("/*", j):
            depth, j = depth + 1, j + 2
        elif src.startswith("*/", j):
            depth, j = depth - 1, j + 2
            if depth == 0:
                return j
        else:
            j += 1
    return len(src)


def quoted_end(src, j, quote):
    while j < len(src) and src[j] != quote:
        j += 2 if src[j] == "\\" else 1
    return min(j + 1, len(src))


def strip_code(src):
    """Comments, strings and char literals blanked; everything else, and every offset, kept."""
    out, i, start = [], 0, 0
    while i < len(src):
        end = literal_end(src, i) if src[i] in "/\"'br" else None
        if end is None:
            i += 1
            continue
        out.append(src[start:i])
        out.append(re.sub(r"[^\n]", " ", src[i:end]))
        i = start = end
    out.append(src[start:])
    return "".join(out)


def matching(code, i, open_ch, close_ch):
    """Index just past the bracket closing the one at `code[i]`."""
    depth = 0
    for j in range(i, len(code)):
        depth += {open_ch: 1, close_ch: -1}.get(code[j], 0)
        if depth == 0:
            return j + 1
    return len(code)


def item_end(code, i):
    """End of the item starting at `i` (after its attributes): its `;` or its `{...}` block."""
    depth = 0
    for j in range(i, len(code)):
        ch = code[j]
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        elif depth == 0 and ch == ";":
            return j + 1
        elif depth == 0 and ch == "{":
            return matching(code, j, "{", "}")
    return len(code)


def skip_attributes(code, i):
    while True:
        while i < len(code) and code[i].isspace():
            i += 1
        if not code.startswith("#[", i):
            return i
        i = matching(code, i + 1, "[", "]")


def blank_test_code(code):
    """Test code blanked: `#[cfg(test)]` items and `mod tests {}` blocks. Also returns the names
    of test-only file modules (`#[cfg(test)] mod testing;`)."""
    test_mods = set()
    for regex in (CFG_TEST_RE, TESTS_MOD_RE):
        match = regex.search(code)
        while match:
            start = match.start()
            item = skip_attributes(code, match.end()) if regex is CFG_TEST_RE else start
            end = item_end(code, item)
            decl = MOD_DECL_RE.match(code[item:end])
            if decl:
                test_mods.add(decl.group(1))
            code = blank(code, start, end)
            match = regex.search(code, end)
    return code, test_mods


# ----------------------------------------------------------------------------- use trees


class Leaf:
    """One path of a `use` declaration or of code: `segments` as written, the name it binds."""

    def __init__(self, segments, binding, offset, public=False, glob=False, text=""):
        self.segments, self.binding, self.offset = tuple(segments), binding, offset
        self.public, self.glob, self.text = public, glob, text


def parse_use_tree(toks, i, prefix, out):
    """Parses one use tree at `toks[i]` (pairs (token, offset)) into Leafs; returns the next index."""
    segs = list(prefix)
    if toks[i][0] == "::":  # `use ::name` : always an external crate
        segs, i = ["::"], i + 1
    while i < len(toks):
        tok, off = toks[i]
        if tok == "{":
            i += 1
            while i < len(toks) and toks[i][0] != "}":
                i = parse_use_tree(toks, i, segs, out)
                i += 1 if i < len(toks) and toks[i][0] == "," else 0
            return i + 1
        if tok == "*":
            out.append(Leaf(segs + ["*"], None, off, glob=True))
            return i + 1
        if i + 1 < len(toks) and toks[i + 1][0] == "::":
            segs.append(tok)
            i += 2
            continue
        path = segs if tok == "self" else segs + [tok]
        binding = path[-1] if path else None
        if i + 2 < len(toks) and toks[i + 1][0] == "as":
            binding, i = (None if toks[i + 2][0] == "_" else toks[i + 2][0]), i + 2
        out.append(Leaf(path, binding, off))
        return i + 1
    return i


def parse_uses(code):
    """The leaves of every `use` declaration, and the code with the declarations blanked."""
    leaves, match = [], USE_RE.search(code)
    while match:
        end = item_end(code, match.end())
        body = code[match.end() : end - 1]
        toks = [(m.group(), match.end() + m.start()) for m in TOKEN_RE.finditer(body)]
        found = []
        if toks:
            parse_use_tree(toks, 0, [], found)
        for leaf in found:
            leaf.public = bool(match.group(1))
            renamed = leaf.binding and leaf.segments and leaf.binding != leaf.segments[-1]
            leaf.text = "use " + "::".join(leaf.segments) + (" as " + leaf.binding if renamed else "")
        leaves += found
        code = blank(code, match.start(), end)
        match = USE_RE.search(code, end)
    return leaves, code


def inline_paths(code):
    """Qualified paths in code (`a::b::c`), as Leafs without binding."""
    return [Leaf(m.group(1).split("::"), None, m.start(1), text=m.group(1)) for m in INLINE_RE.finditer(code)]


def defined_items(code):
    return {next(g for g in m.groups() if g) for m in ITEM_RE.finditer(code)}


# ----------------------------------------------------------------------------- crate model


class SourceFile:
    """One .rs file of the library: module path, use leaves, code paths, top-level items."""

    def __init__(self, rel, modpath, src):
        self.rel, self.modpath = rel, modpath
        code, self.test_mods = blank_test_code(strip_code(src))
        self.uses, rest = parse_uses(code)
        self.paths = inline_paths(rest)
        self.words = set(re.findall(IDENT, rest))  # names the code uses, outside `use` lines
        self.items = defined_items(code)
        self.aliases = {}  # binding -> absolute module path, filled by Crate
        self.line_starts = [0] + [m.end() for m in re.finditer("\n", src)]

    def line(self, offset):
        return bisect.bisect_right(self.line_starts, offset)

    def __str__(self):
        return self.rel


def module_path(rel):
    """src-relative file path -> module path (tuple), or None for binary and non-Rust files."""
    parts = rel.replace(os.sep, "/").split("/")
    if parts[0] == "bin" or not rel.endswith(".rs") or parts == ["main.rs"]:
        return None
    parts[-1] = parts[-1][:-3]
    if parts[-1] in ("mod", "lib") and (parts[-1] == "mod" or len(parts) == 1):
        parts.pop()
    return tuple(parts)


class Crate:
    """The library's files keyed by module path, with the resolver over them."""

    def __init__(self, name, sources, prefix=""):
        """`sources`: {src-relative path: text}; `prefix` is put before paths when printed."""
        self.name, self.modules = name, {}
        for rel, src in sorted(sources.items()):
            modpath = module_path(rel)
            if modpath is not None:
                self.modules[modpath] = SourceFile(prefix + rel, modpath, src)
        self.drop_test_modules()
        self.folders = {m[:i] for m in self.modules for i in range(1, len(m) + 1)}
        for _ in range(2):  # an alias may be written through another alias
            for f in self.modules.values():
                f.aliases = self.module_aliases(f)

    def drop_test_modules(self):
        test_only = {f.modpath + (name,) for f in self.modules.values() for name in f.test_mods}
        for modpath in list(self.modules):
            if any(modpath[: len(t)] == t for t in test_only):
                del self.modules[modpath]

    def module_aliases(self, f):
        aliases = {}
        for leaf in f.uses:
            absolute = self.absolute(f, leaf.segments) if leaf.binding and not leaf.glob else None
            if absolute is not None and absolute in self.modules:
                aliases[leaf.binding] = absolute
        return aliases

    def absolute(self, f, segments):
        """Path written in `f` -> absolute path in the crate, or None when it leaves the crate."""
        if not segments:
            return None
        head, rest = segments[0], tuple(segments[1:])
        if head in ("crate", "$crate"):
            return rest
        if head == "self":
            return f.modpath + rest
        if head == "super":
            ups = next((i for i, s in enumerate(segments) if s != "super"), len(segments))
            return f.modpath[: len(f.modpath) - ups] + tuple(segments[ups:]) if ups <= len(f.modpath) else None
        if f.modpath + (head,) in self.folders:
            return f.modpath + tuple(segments)
        if head in f.aliases:
            return f.aliases[head] + rest
        return None

    def locate(self, absolute, depth=0):
        """(defining file, found) for an absolute path; file None for items of other crates."""
        i, walked = 0, 0
        while walked < len(absolute) and absolute[: walked + 1] in self.folders:
            walked += 1  # a folder may lack its mod.rs (mid-move): walk through it
            i = walked if absolute[:walked] in self.modules else i
        f, rest = self.modules.get(absolute[:i]), absolute[i:]
        if f is None:  # no lib.rs
            return None, True
        if not rest or rest[0] == "*":
            return f, True
        if depth >= MAX_DEPTH:
            return f, False
        for leaf in f.uses:
            if leaf.binding == rest[0] and not leaf.glob:
                target = self.absolute(f, leaf.segments)
                return self.locate(target + rest[1:], depth + 1) if target is not None else (None, True)
        if rest[0] in f.items:
            return f, True
        return self.through_globs(f, rest, depth)

    def through_globs(self, f, rest, depth):
        for leaf in f.uses:
            target = self.absolute(f, leaf.segments[:-1]) if leaf.glob else None
            if target is not None and target != f.modpath:
                found = self.locate(target + rest, depth + 1)
                if found[1] and found[0] is not None:
                    return found
        return f, False

    def resolve(self, f, segments):
        """File defining what `segments`, written in `f`, names; None outside the crate."""
        absolute = self.absolute(f, segments)
        return None if absolute is None else self.locate(absolute)[0]


# ----------------------------------------------------------------------------- graphs


class Arrow:
    """A witness of an arrow: the file and line that write it, the path, the file it reaches."""

    def __init__(self, source, line, text, target):
        self.source, self.line, self.text, self.target = source, line, text, target



def witness_lines(arrows):
    """One line per file:line: the paths written there (`a::{B, c}` when several) and targets."""
    by_line = defaultdict(list)
    for w in arrows:
        by_line[(w.source.rel, w.line)].append(w)
    out = []
    for (rel, line), ws in sorted(by_line.items()):
        texts = list(dict.fromkeys(w.text for w in ws))
        targets = ", ".join(dict.fromkeys(short(w.target) for w in ws))
        out.append("%s:%d  %s  (-> %s)" % (rel, line, merge_paths(texts), targets))
    return out


def merge_paths(texts):
    """["use a::b::C", "use a::b::d"] -> "use a::b::{C, d}"."""
    if len(texts) == 1:
        return texts[0]
    split = [t.split("::") for t in texts]
    common = 0
    while all(len(p) > common + 1 for p in split) and len({p[common] for p in split}) == 1:
        common += 1
    tails = ", ".join("::".join(p[common:]) for p in split)
    return "::".join(split[0][:common] + ["{%s}" % tails]) if common else tails


def file_arrows(crate):
    """{(source file, target file): [Arrow]} over the crate's library files."""
    graph = defaultdict(list)
    for f in crate.modules.values():
        used_aliases = {leaf.segments[0] for leaf in f.paths} & set(f.aliases)
        # A re-export is an arrow only when the file's own code uses the name too.
        imports = [
            leaf
            for leaf in f.uses
            if (not leaf.public or leaf.binding in f.words) and leaf.binding not in used_aliases
        ]
        for leaf in imports + f.paths:  # not pass-through re-exports, nor aliases whose uses in code give arrows
            target = crate.resolve(f, leaf.segments)
            if target is not None and target is not f:
                graph[(f, target)].append(Arrow(f, f.line(leaf.offset), leaf.text, target))
    return graph


def top_module(f):
    return f.modpath[0] if f.modpath else "lib.rs"


def folder_arrows(graph):
    """File arrows collapsed onto top-level modules: {(module, module): [Arrow]}."""
    folders = defaultdict(list)
    for (a, b), arrows in graph.items():
        if top_module(a) != top_module(b):
            folders[(top_module(a), top_module(b))] += arrows
    return folders


def components(edges):
    """Strongly connected components of more than one node (Tarjan, iterative), sorted."""
    succ = defaultdict(set)
    for a, b in edges:
        succ[a].add(b)
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    for root in sorted(succ, key=str):
        if root not in index:
            tarjan_visit(root, succ, index, low, stack, on_stack, found)
    return sorted((sorted(c, key=str) for c in found if len(c) > 1), key=lambda c: str(c[0]))


def tarjan_visit(root, succ, index, low, stack, on_stack, found):
    work = [(root, iter(sorted(succ[root], key=str)))]
    index[root] = low[root] = len(index)
    stack.append(root), on_stack.add(root)
    while work:
        node, children = work[-1]
        child = next(children, None)
        if child is None:
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                found.append(pop_component(node, stack, on_stack))
        elif child not in index:
            index[child] = low[child] = len(index)
            stack.append(child), on_stack.add(child)
            work.append((child, iter(sorted(succ[child], key=str))))
        elif child in on_stack:
            low[node] = min(low[node], index[child])


def pop_component(node, stack, on_stack):
    component = []
    while True:
        top = stack.pop()
        on_stack.discard(top)
        component.append(top)
        if top == node:
            return component


def chains(component, edges):
    """Elementary cycles within a component (each from its smallest node), at most MAX_CHAINS."""
    order = {n: i for i, n in enumerate(component)}
    succ = defaultdict(list)
    for a, b in sorted(edges, key=str):
        if a in order and b in order:
            succ[a].append(b)
    found = []
    for start in component:
        walk = [(start, iter(succ[start]))]
        while walk and len(found) < MAX_CHAINS:
            node, nexts = walk[-1]
            child = next(nexts, None)
            if child is None:
                walk.pop()
            elif child == start:
                found.append([n for n, _ in walk] + [start])
            elif order[child] > order[start] and child not in [n for n, _ in walk]:
                walk.append((child, iter(succ[child])))
    return found


# ----------------------------------------------------------------------------- report


def short(node):
    return node.rel.split("/src/", 1)[-1] if hasattr(node, "rel") else str(node)


def describe(kind, component, edges, out):
    """Prints one cycle: its elementary chains, then every arrow inside it with its lines."""
    names = ", ".join(short(n) for n in component)
    out.append("  %s cycle (%d): %s" % (kind, len(component), names))
    found = chains(component, edges)
    for chain in found:
        out.append("    " + " -> ".join(short(n) for n in chain))
    if len(found) == MAX_CHAINS:
        out.append("    ... (more chains not listed)")
    members = set(component)
    for (a, b), arrows in sorted(edges.items(), key=lambda e: (str(short(e[0][0])), str(short(e[0][1])))):
        if a in members and b in members:
            out.append("    arrow %s -> %s:" % (short(a), short(b)))
            out += ["      " + line for line in witness_lines(arrows)]


def report(crate, out):
    """Appends the crate's cycles to `out`; returns how many there are."""
    graph = file_arrows(crate)
    folders = folder_arrows(graph)
    file_cycles, folder_cycles = components(graph), components(folders)
    out.append(
        "%s: %d files, %d arrows; %d file cycle(s), %d folder cycle(s)"
        % (crate.name, len(crate.modules), len(graph), len(file_cycles), len(folder_cycles))
    )
    for component in file_cycles:
        describe("file", component, graph, out)
    for component in folder_cycles:
        describe("folder", component, folders, out)
    return len(file_cycles) + len(folder_cycles)


def dot(crates):
    """The file graphs as Graphviz DOT: one cluster per crate and folder; cycle arrows red."""
    out = ["digraph imports {", "  rankdir=LR;", "  node [shape=box, fontsize=10];"]
    for crate in crates:
        graph = file_arrows(crate)
        cycle_of = {n: i for i, c in enumerate(components(graph)) for n in c}
        out.append('  subgraph "cluster_%s" {\n    label="%s";' % (crate.name, crate.name))
        by_folder = defaultdict(list)
        for f in crate.modules.values():
            by_folder[top_module(f)].append(f)
        for folder, files in sorted(by_folder.items()):
            out.append('    subgraph "cluster_%s_%s" {\n      label="%s";' % (crate.name, folder, folder))
            out += ['      "%s" [label="%s"];' % (f.rel, short(f)) for f in files]
            out.append("    }")
        out.append("  }")
        for (a, b) in sorted(graph, key=lambda e: (e[0].rel, e[1].rel)):
            red = " [color=red]" if a in cycle_of and cycle_of[a] == cycle_of.get(b) else ""
            out.append('  "%s" -> "%s"%s;' % (a.rel, b.rel, red))
    out.append("}")
    return "\n".join(out)


# ----------------------------------------------------------------------------- loading, CLI


def repo_root():
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load_crate(root, name):
    src_dir = os.path.join(root, name, "src")
    sources = {}
    for folder, _, files in os.walk(src_dir):
        for file in files:
            if file.endswith(".rs"):
                path = os.path.join(folder, file)
                with open(path, encoding="utf-8") as handle:
                    sources[os.path.relpath(path, src_dir).replace(os.sep, "/")] = handle.read()
    return Crate(name, sources, prefix=name + "/src/")


def crate_names(root, requested):
    if requested:
        missing = [n for n in requested if not os.path.isdir(os.path.join(root, n, "src"))]
        if missing:
            sys.exit("no crate source folder: " + ", ".join(os.path.join(root, n, "src") for n in missing))
        return requested
    return sorted(n for n in os.listdir(root) if n.startswith("starnet-") and os.path.isdir(os.path.join(root, n, "src")))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--crate", action="append", help="crate folder (repeatable); default every starnet-*/src")
    parser.add_argument("--dot", action="store_true", help="print a Graphviz DOT graph instead of the report")
    parser.add_argument("--self-test", action="store_true", help="run the resolver's unit tests")
    args = parser.parse_args(argv)
    if args.self_test:
        suite = unittest.defaultTestLoader.loadTestsFromTestCase(SelfTest)
        return 0 if unittest.TextTestRunner(verbosity=1).run(suite).wasSuccessful() else 1
    root = repo_root()
    crates = [load_crate(root, name) for name in crate_names(root, args.crate)]
    out, cycles = [], 0
    for crate in crates:
        cycles += report(crate, out)
    print(dot(crates) if args.dot else "\n".join(out))
    return 1 if cycles else 0


# ----------------------------------------------------------------------------- self-test


def arrows_of(sources):
    """{(source, target)} as src-relative paths, for a crate made of `sources`."""
    return {(a.rel, b.rel) for a, b in file_arrows(Crate("t", sources))}


class SelfTest(unittest.TestCase):
    def test_strip_comments_strings(self):
        code = strip_code('let s = "crate::a"; // crate::b\n/* crate::c /* */ */ r#"crate::d"# \'"\' x::y')
        self.assertNotIn("crate", code)
        self.assertIn("x::y", code)
        self.assertEqual(strip_code("a\n// x\nb").count("\n"), 2)

    def test_strip_lifetimes_and_chars(self):
        code = strip_code("fn f<'a>(x: &'a str) -> char { let q = '\\''; let d = '\"'; crate::k::g() }")
        self.assertIn("<'a>", code)
        self.assertIn("crate::k::g", code)
        self.assertNotIn('"', code)

    def test_use_trees(self):
        leaves, _ = parse_uses("pub(crate) use a::{b, c::{self, d as e, *}};\nuse ::x::y;")
        got = [(l.segments, l.binding, l.glob, l.public) for l in leaves]
        self.assertEqual(got[0], (("a", "b"), "b", False, True))
        self.assertEqual(got[1], (("a", "c"), "c", False, True))
        self.assertEqual(got[2], (("a", "c", "d"), "e", False, True))
        self.assertEqual(got[3], (("a", "c", "*"), None, True, True))
        self.assertEqual(got[4], (("::", "x", "y"), "y", False, False))

    def test_reexport_followed_to_defining_file(self):
        sources = {
            "lib.rs": "pub mod m;\npub mod k;\npub use m::Thing as Alias;\n",
            "m/mod.rs": "mod inner;\npub use inner::*;\npub use self::inner::{Other};\n",
            "m/inner.rs": "pub struct Thing;\npub fn other() {}\npub struct Other;\n",
            "k.rs": "use crate::Alias;\nuse crate::m::Other;\nfn f() { crate::m::other(); }\n",
        }
        self.assertEqual(arrows_of(sources), {("k.rs", "m/inner.rs")})

    def test_super_child_and_alias_paths(self):
        sources = {
            "lib.rs": "pub mod a;\n",
            "a/mod.rs": "mod b;\nmod c;\npub fn top() {}\nfn g() { b::h(); }\n",
            "a/b.rs": "pub fn h() { super::top(); }\n",
            "a/c.rs": "use super::b::{self};\nfn k() { b::h(); }\n",
        }
        want = {("a/mod.rs", "a/b.rs"), ("a/b.rs", "a/mod.rs"), ("a/c.rs", "a/b.rs")}
        self.assertEqual(arrows_of(sources), want)

    def test_a_reexport_the_file_uses_is_an_arrow(self):
        sources = {
            "lib.rs": "pub mod a;\n",
            "a/mod.rs": "mod b;\npub use b::B;\npub fn top() -> B { B }\n",
            "a/b.rs": "pub struct B;\nfn g() { super::top(); }\n",
        }
        self.assertEqual(arrows_of(sources), {("a/mod.rs", "a/b.rs"), ("a/b.rs", "a/mod.rs")})

    def test_restricted_reexports_relative_paths_inline_mods(self):
        sources = {
            "lib.rs": "pub mod f;\npub mod g;\n",
            "f.rs": "mod sub;\npub(crate) use sub::S;\nuse sub::T;\n",
            "f/sub.rs": "pub struct S;\npub struct T;\n",
            "g.rs": "use crate::f::S;\nuse crate::g::inner::I;\npub mod inner {\n    pub struct I;\n}\n",
        }
        self.assertEqual(arrows_of(sources), {("f.rs", "f/sub.rs"), ("g.rs", "f/sub.rs")})

    def test_merge_paths(self):
        self.assertEqual(merge_paths(["use a::b::C", "use a::b::d"]), "use a::b::{C, d}")
        self.assertEqual(merge_paths(["x::y"]), "x::y")

    def test_folder_without_mod_file(self):
        sources = {"lib.rs": "pub mod a;\n", "a.rs": "use crate::cmd::run::go;\n", "cmd/run.rs": "pub fn go() {}\n"}
        self.assertEqual(arrows_of(sources), {("a.rs", "cmd/run.rs")})

    def test_test_code_bins_and_externals_skipped(self):
        sources = {
            "lib.rs": "pub mod a;\npub mod b;\n#[cfg(test)]\nmod testing;\n",
            "a.rs": "use std::fmt;\nuse serde::X;\n#[cfg(test)]\nmod tests {\n    use crate::b::f;\n}\n",
            "b.rs": "/// [`crate::a::x`]\npub fn f() { let s = \"crate::a::y\"; }\n",
            "testing.rs": "use crate::a::Z;\n",
            "bin/tool.rs": "use crate::a::Z;\n",
        }
        self.assertEqual(arrows_of(sources), set())

    def test_cycles_files_and_folders(self):
        sources = {
            "lib.rs": "pub mod x;\npub mod y;\n",
            "x/mod.rs": "mod p;\nmod q;\npub use p::P;\n",
            "x/p.rs": "use super::q::Q;\npub struct P;\n",
            "x/q.rs": "use crate::y::Y;\npub struct Q;\nfn f() { super::p::P; }\n",
            "y.rs": "pub struct Y;\nfn g() { crate::x::P; }\n",
        }
        crate = Crate("t", sources)
        graph = file_arrows(crate)
        file_cycles = [[short(n) for n in c] for c in components(graph)]
        self.assertEqual(file_cycles, [["x/p.rs", "x/q.rs", "y.rs"]])
        self.assertEqual(components(folder_arrows(graph)), [["x", "y"]])
        self.assertEqual(len(chains(components(graph)[0], graph)), 2)


if __name__ == "__main__":
    sys.exit(main())
