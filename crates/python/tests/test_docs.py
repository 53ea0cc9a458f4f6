"""The docstrings' examples run and give what they show; the .pyi stub declares what the package
exports, with the same parameters."""

import doctest

import octowrap


def test_docstring_examples():
    result = doctest.testmod(octowrap, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 10
    assert result.failed == 0


def stub():
    """The ``.pyi`` stub's top-level definitions: name -> ast node."""
    import ast
    from pathlib import Path

    tree = ast.parse((Path(octowrap.__file__).parent / "__init__.pyi").read_text())
    out = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            out[node.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out[node.target.id] = node
        elif isinstance(node, ast.Assign):
            out.update({t.id: node for t in node.targets if isinstance(t, ast.Name)})
    return out


def params(fn):
    """A stub function's parameter names, ``self`` left out."""
    a = fn.args
    return [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg != "self"]


def test_the_stub_declares_every_public_name_with_the_runtime_parameters():
    import ast
    import inspect

    s = stub()
    missing = [name for name in octowrap.__all__ if name not in s]
    assert not missing, f"the .pyi stub lacks {missing}"
    for name in octowrap.__all__:
        obj = getattr(octowrap, name)
        if inspect.isfunction(obj):
            assert params(s[name]) == list(inspect.signature(obj).parameters), name
            assert obj.__doc__ and ">>>" in obj.__doc__ or name in ("open_mrq", "write"), f"{name} has no example"
        elif inspect.isclass(obj) and isinstance(s[name], ast.ClassDef):
            methods = {n.name: n for n in s[name].body if isinstance(n, ast.FunctionDef)}
            for m, fn in vars(obj).items():
                if inspect.isfunction(fn) and not m.startswith("_"):
                    assert m in methods, f"the stub lacks {name}.{m}"
                    assert params(methods[m]) == [p for p in inspect.signature(fn).parameters if p != "self"], f"{name}.{m}"
