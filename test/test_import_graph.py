"""No import circle among the modules of robot_control and sim_bridge.

The graph is read from the source with ast: module A -> module B when A imports B anywhere (at the
top, inside a function, relative or absolute). `from P import name` points at the submodule P.name
when there is one, else at P itself (its __init__.py); `import P.Q` at P.Q.
"""
import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGES = ('robot_control', 'sim_bridge')


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
