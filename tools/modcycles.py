#!/usr/bin/env python3
"""The module-level import graph of hdrvis's src/: prints the cycles between modules (files) and
the edges between top-level layers. With --check, exits 1 on a cycle or on an edge the
architecture forbids (docs/architecture.md): model -> datasets/io/gpu, gpu -> datasets, and any
edge from a lower layer up into render, tonemap, script, tui, bench or cli; or on a layer naming
an external crate kept to others (wgpu to gpu/render/tonemap, rhai to script, ratatui,
ratatui-image and crossterm to tui).

    python3 tools/modcycles.py src [--check]
"""
import os, re, sys
args = [a for a in sys.argv[1:] if not a.startswith('--')]
check = '--check' in sys.argv
root = args[0] if args else 'src'
mods = {}
crate_uses = {}
for dp, _, fs in os.walk(root):
    for f in fs:
        if not f.endswith('.rs'): continue
        p = os.path.join(dp, f)
        rel = os.path.relpath(p, root)[:-3].split(os.sep)
        if rel[-1] in ('mod', 'lib', 'main'): rel = rel[:-1]
        mods['::'.join(rel)] = p
def strip_tests(src):
    i = src.find('#[cfg(test)]')
    return src if i < 0 else src[:i]
def resolve(cur, path):
    parts = path.split('::')
    if parts[0] == 'crate': base = []; parts = parts[1:]
    elif parts[0] == 'super':
        base = cur.split('::')[:-1] if cur else []
        parts = parts[1:]
        while parts and parts[0] == 'super': base = base[:-1]; parts = parts[1:]
    elif parts[0] == 'self': base = cur.split('::') if cur else []; parts = parts[1:]
    else: return None
    full = base + parts
    for n in range(len(full), 0, -1):
        k = '::'.join(full[:n])
        if k in mods: return k
    return None
edges = {m: set() for m in mods}
pat = re.compile(r'\b((?:crate|super|self)(?:::[A-Za-z_][A-Za-z0-9_]*)+)')
for m, p in mods.items():
    src = strip_tests(open(p).read())
    src = re.sub(r'//.*', '', src)
    for c in re.findall(r'\b(wgpu|rhai|ratatui_image|ratatui|crossterm)::', src):
        crate_uses.setdefault(c, set()).add(m.split('::')[0] or 'lib')
    # expand `use x::{a, b::c}` groups
    for g in re.finditer(r'use\s+((?:crate|super|self)(?:::\w+)*)::\{([^;]*)\};', src, re.S):
        for item in re.split(r'[,\s]+', g.group(2)):
            item = item.strip('{}')
            if item and item != 'self':
                t = resolve(m, g.group(1) + '::' + item.split('::')[0] + ('::' + '::'.join(item.split('::')[1:]) if '::' in item else ''))
                if t and t != m and not m.startswith(t + '::') : edges[m].add(t)
    for u in pat.finditer(src):
        t = resolve(m, u.group(1))
        if t and t != m and not m.startswith(t + '::') and t != '':
            edges[m].add(t)
# Tarjan
idx = {}; low = {}; st = []; on = set(); sccs = []; c = [0]
sys.setrecursionlimit(10000)
def sc(v):
    idx[v] = low[v] = c[0]; c[0] += 1; st.append(v); on.add(v)
    for w in edges[v]:
        if w not in idx: sc(w); low[v] = min(low[v], low[w])
        elif w in on: low[v] = min(low[v], idx[w])
    if low[v] == idx[v]:
        comp = []
        while True:
            w = st.pop(); on.discard(w); comp.append(w)
            if w == v: break
        if len(comp) > 1: sccs.append(sorted(comp))
for v in mods:
    if v not in idx: sc(v)
for comp in sccs:
    print('cycle:', ' <-> '.join(comp))
    for a in comp:
        for b in sorted(edges[a] & set(comp)): print('   ', a, '->', b)
if not sccs: print('no module cycles among', len(mods), 'modules')
top = {}
for a, bs in edges.items():
    for b in bs:
        ta, tb = a.split('::')[0], b.split('::')[0]
        if ta != tb: top.setdefault(ta, set()).add(tb)
for a in sorted(top): print('layer', a, '->', ', '.join(sorted(top[a])))

FORBIDDEN = {
    'model': {'datasets', 'io', 'gpu', 'render', 'tonemap', 'script', 'tui', 'bench', 'cli'},
    'io': {'datasets', 'gpu', 'render', 'tonemap', 'script', 'tui', 'bench', 'cli'},
    'datasets': {'gpu', 'render', 'tonemap', 'script', 'tui', 'bench', 'cli'},
    'gpu': {'datasets', 'render', 'tonemap', 'script', 'tui', 'bench', 'cli'},
    'tonemap': {'render', 'script', 'tui', 'bench', 'cli'},
    'render': {'script', 'tui', 'bench', 'cli'},
    'script': {'tui', 'bench', 'cli'},
}
bad = [(a, b) for a in top for b in top[a] if b in FORBIDDEN.get(a, ())]
for a, b in bad: print('forbidden layer edge:', a, '->', b)
CRATE_LAYERS = {
    'wgpu': {'gpu', 'render', 'tonemap'},
    'rhai': {'script'},
    'ratatui': {'tui'},
    'ratatui_image': {'tui'},
    'crossterm': {'tui'},
}
for c in sorted(crate_uses): print('crate', c, 'used by', ', '.join(sorted(crate_uses[c])))
bad_crates = [(layer, c) for c, layers in crate_uses.items() for layer in sorted(layers - CRATE_LAYERS[c])]
for layer, c in bad_crates: print('forbidden crate use:', layer, 'uses', c)
if check and (sccs or bad or bad_crates): sys.exit(1)
