"""No import circle among the modules of robot_control and sim_bridge, and no import anywhere in the
checkout of a first-party module or name that is not there (a module moved, a name renamed).

The graph is read from the source with ast: module A -> module B when A imports B anywhere (at the
top, inside a function, relative or absolute). `from P import name` points at the submodule P.name
when there is one, else at P itself (its __init__.py); `import P.Q` at P.Q.
"""
import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGES = ('robot_control', 'sim_bridge')
#: the checkout's own importable folders: the installed packages and the workshop beside them
FIRST_PARTY = PACKAGES + ('benchmarks', 'dev')
#: every folder of the checkout with Python source
SOURCES = FIRST_PARTY + ('test', 'launch')


def modules(root, packages):
    """{dotted module name: source path} of every .py file under the packages in `root`."""
    found = {}
    for package in packages:
        for folder, _, files in os.walk(os.path.join(root, package)):
            for name in files:
                if name.endswith('.py'):
                    path = os.path.join(folder, name)
                    dotted = os.path.relpath(path, root)[:-3].replace(os.sep, '.')
                    found[dotted.removesuffix('.__init__')] = path
    return found


def _imported(node, package):
    """Dotted names an Import/ImportFrom node reaches (candidates: 'P.name' and 'P' for each from-import)."""
    if isinstance(node, ast.Import):
        return [[a.name] for a in node.names]
    base = node.module or ''
    if node.level:
        parts = package.split('.')[:len(package.split('.')) - node.level + 1]
        base = '.'.join(parts + ([node.module] if node.module else []))
    return [[f'{base}.{a.name}', base] for a in node.names]


def import_graph(root, packages):
    """{module: set of the package modules it imports} (no self-edges)."""
    known = modules(root, packages)
    graph = {}
    for name, path in known.items():
        package = name if path.endswith('__init__.py') else name.rpartition('.')[0]
        with open(path, encoding='utf-8') as f:
            tree = ast.parse(f.read(), path)
        targets = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for candidates in _imported(node, package):
                    targets.update(next(([c] for c in candidates if c in known), []))
        graph[name] = targets - {name}
    return graph


def circle(graph):
    """One import circle [a, b, ..., a] of `graph`, or None (depth-first search for a back edge)."""
    state, path = {}, []

    def visit(node):
        state[node] = 'open'
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 'open':
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        state[node] = 'done'
        path.pop()
        return None

    for start in sorted(graph):
        if start not in state and (found := visit(start)):
            return found
    return None


def _bound_names(path):
    """Names a module binds at its top level (in if/try blocks too, not inside functions or classes)."""
    with open(path, encoding='utf-8') as f:
        todo = list(ast.parse(f.read(), path).body)
    names = set()
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split('.')[0] for a in node.names)
        targets = (node.targets if isinstance(node, ast.Assign)
                   else [node.target] if isinstance(node, (ast.AnnAssign, ast.AugAssign, ast.For))
                   else [i.optional_vars for i in node.items] if isinstance(node, ast.With) else [])
        names.update(n.id for t in targets if t for n in ast.walk(t) if isinstance(n, ast.Name))
        todo.extend(c for c in ast.iter_child_nodes(node) if isinstance(c, ast.stmt))
    return names


def unresolved_imports(root, folders, first_party):
    """'path:line: name' of each import, in the .py files under `folders` of `root`, of a module of the
    `first_party` packages that does not exist, or of a name its module does not bind."""
    known = modules(root, first_party)
    packages = {name.rsplit('.', i)[0] for name in known for i in range(name.count('.') + 1)}
    bound = {}
    bad = []
    for folder in folders:
        for path in sorted(modules(root, [folder]).values()):
            with open(path, encoding='utf-8') as f:
                tree = ast.parse(f.read(), path)
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names if a.name.split('.')[0] in first_party]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module.split('.')[0] in first_party:
                    base = node.module
                    if base not in known and base not in packages:
                        names = [base]
                    else:
                        names = [f'{base}.{a.name}' for a in node.names if a.name != '*'
                                 and (base not in known or a.name not in bound.setdefault(base, _bound_names(known[base])))]
                else:
                    continue
                where = os.path.relpath(path, root)
                bad += [f'{where}:{node.lineno}: {n}' for n in names if n not in known and n not in packages]
    return bad


def test_every_first_party_import_names_a_module_or_name_that_exists():
    bad = unresolved_imports(ROOT, [f for f in SOURCES if os.path.isdir(os.path.join(ROOT, f))], FIRST_PARTY)
    assert bad == [], 'imports of what is not there:\n' + '\n'.join(bad)


def test_the_import_check_finds_a_missing_module_and_a_missing_name(tmp_path):
    (tmp_path / 'pkg').mkdir()
    (tmp_path / 'ws').mkdir()
    (tmp_path / 'test').mkdir()
    (tmp_path / 'pkg' / '__init__.py').write_text('try:\n    X = 1\nexcept ImportError:\n    pass\nfor Z in ():\n    pass\n')
    (tmp_path / 'pkg' / 'a.py').write_text('A = 1\n')
    (tmp_path / 'ws' / 'b.py').write_text('from pkg.a import A, B\n')
    (tmp_path / 'test' / 't.py').write_text('import os\nimport pkg.a\nimport pkg.gone\nfrom pkg import X, Z, a, Y\n\n\n'
                                           'def f():\n    from ws import b, c\n')
    assert unresolved_imports(str(tmp_path), ['pkg', 'ws', 'test'], ('pkg', 'ws')) == \
        ['ws/b.py:1: pkg.a.B', 'test/t.py:3: pkg.gone', 'test/t.py:4: pkg.Y', 'test/t.py:8: ws.c']


def test_the_package_modules_import_each_other_without_a_circle():
    graph = import_graph(ROOT, PACKAGES)
    assert {'robot_control.tools.plot', 'robot_control.tools.bag_tracking', 'sim_bridge.bridge_node'} <= set(graph)
    assert 'robot_control.tools.bag_tracking' in graph['robot_control.tools.plot']    # a function-level import
    found = circle(graph)
    assert found is None, 'import circle: ' + ' -> '.join(found)


def test_the_check_finds_a_circle_through_a_function_level_and_a_relative_import(tmp_path):
    pkg = tmp_path / 'pkg'
    (pkg / 'sub').mkdir(parents=True)
    (pkg / '__init__.py').write_text('')
    (pkg / 'sub' / '__init__.py').write_text('')
    (pkg / 'a.py').write_text('from pkg.sub import b\n')
    (pkg / 'sub' / 'b.py').write_text('import os\n\n\ndef f():\n    from .c import g\n    return g\n')
    (pkg / 'sub' / 'c.py').write_text('def g():\n    from ..a import b\n    return b\n')
    graph = import_graph(str(tmp_path), ['pkg'])
    assert graph['pkg.a'] == {'pkg.sub.b'} and graph['pkg.sub.b'] == {'pkg.sub.c'} and graph['pkg.sub.c'] == {'pkg.a'}
    assert circle(graph) == ['pkg.a', 'pkg.sub.b', 'pkg.sub.c', 'pkg.a']
    (pkg / 'sub' / 'c.py').write_text('def g():\n    return 1\n')
    assert circle(import_graph(str(tmp_path), ['pkg'])) is None
