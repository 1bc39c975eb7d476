# The type stubs (python/dsmplan.pyi) and the docstrings cannot fall behind the module: every
# public name of dsmplan, and every public attribute and method of its classes, has a docstring
# that documents each of its parameters, and is in the .pyi with the same parameters (names,
# order, keyword-only or not, with a default or not). The module's signatures are read from the
# first line of pybind11's docstrings; the .pyi is parsed with Python's ast, not imported.
import ast
import inspect
import os

import pytest

import dsmplan

STUB = os.path.join(os.path.dirname(dsmplan.__file__), "dsmplan.pyi")


def public(names):
    return sorted(name for name in names if not name.startswith("_"))


def parameters(args):
    """(name, keyword-only, has a default) of every parameter of an ast.arguments but self."""
    positional = args.posonlyargs + args.args
    defaults = [False] * (len(positional) - len(args.defaults)) + [True] * len(args.defaults)
    out = [(a.arg, False, d) for a, d in zip(positional, defaults)]
    out += [(a.arg, True, d is not None) for a, d in zip(args.kwonlyargs, args.kw_defaults)]
    return [p for p in out if p[0] != "self"]


def stub_names():
    """{name: node} of the .pyi's top level, and {class: {name: node}} of its classes."""
    tree = ast.parse(open(STUB).read(), STUB)
    top, classes = {}, {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            top[node.name] = node
        elif isinstance(node, ast.AnnAssign):
            top[node.target.id] = node
        if isinstance(node, ast.ClassDef):
            classes[node.name] = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
    return top, classes


def module_signature(function, name):
    """The parameters of a pybind11 function from its docstring's first line, "name(a: T, *, b: U = 1) -> R",
    parsed as a Python def (the types are expressions; the defaults are reprs)."""
    first = (function.__doc__ or "").split("\n", 1)[0]
    assert first.startswith(name + "("), f"{name}: no signature line in its docstring: {first!r}"
    node = ast.parse(f"def {first}: ...").body[0]
    return parameters(node.args)


def doc_body(function, name):
    """The docstring without pybind11's signature line."""
    doc = function.__doc__ or ""
    return doc.split("\n", 1)[1].strip() if doc.startswith(name + "(") else doc.strip()


def public_functions_and_classes():
    for name in public(dir(dsmplan)):
        yield name, getattr(dsmplan, name)


def members(cls):
    """The public names a class defines itself (not what it inherits from object or Exception),
    and __init__ when it has a constructor (pybind11's stand-in for none has no signature)."""
    names = public(vars(cls))
    if (getattr(vars(cls).get("__init__"), "__doc__", None) or "").startswith("__init__("):
        names.append("__init__")
    return names


def test_every_public_name_has_a_docstring_documenting_its_parameters():
    missing = []
    for name, value in public_functions_and_classes():
        if not (value.__doc__ or "").strip():
            missing.append(name)
        if callable(value) and not inspect.isclass(value):
            body = doc_body(value, name)
            if not body:
                missing.append(name)
            for parameter, _, _ in module_signature(value, name):
                if f"{parameter}:" not in body and f"`{parameter}`" not in body:
                    missing.append(f"{name}({parameter})")
        if inspect.isclass(value):
            for member in members(value):
                attribute = vars(value)[member]
                if isinstance(attribute, property):
                    if not (attribute.__doc__ or "").strip():
                        missing.append(f"{name}.{member}")
                    continue
                body = doc_body(attribute, member)
                if not body:
                    missing.append(f"{name}.{member}")
                for parameter, _, _ in module_signature(attribute, member):
                    if f"{parameter}:" not in body and f"`{parameter}`" not in body:
                        missing.append(f"{name}.{member}({parameter})")
    assert not missing, f"without a docstring (or an argument it leaves out): {missing}"


def test_every_public_name_is_in_the_stubs_with_the_same_parameters():
    top, classes = stub_names()
    problems = []
    for name, value in public_functions_and_classes():
        if name not in top:
            problems.append(f"{name} is not in {os.path.basename(STUB)}")
            continue
        if inspect.isclass(value):
            if not isinstance(top[name], ast.ClassDef):
                problems.append(f"{name} is a class, not one in the stubs")
                continue
            for member in members(value):
                if member not in classes[name]:
                    problems.append(f"{name}.{member} is not in the stubs")
                    continue
                attribute = vars(value)[member]
                stub = classes[name][member]
                is_property = any(getattr(d, "id", None) == "property" for d in stub.decorator_list)
                if isinstance(attribute, property):
                    if not is_property:
                        problems.append(f"{name}.{member} is a property, not one in the stubs")
                elif parameters(stub.args) != module_signature(attribute, member):
                    problems.append(
                        f"{name}.{member}: stub {parameters(stub.args)} != module {module_signature(attribute, member)}"
                    )
        elif callable(value):
            if not isinstance(top[name], ast.FunctionDef):
                problems.append(f"{name} is a function, not one in the stubs")
            elif parameters(top[name].args) != module_signature(value, name):
                problems.append(f"{name}: stub {parameters(top[name].args)} != module {module_signature(value, name)}")
    # And nothing in the stubs the module does not have.
    for name in top:
        if not name.startswith("_") and not hasattr(dsmplan, name):
            problems.append(f"{name} is in the stubs, not in the module")
    for cls, names in classes.items():
        for member in names:
            if hasattr(dsmplan, cls) and not hasattr(getattr(dsmplan, cls), member):
                problems.append(f"{cls}.{member} is in the stubs, not in the module")
    assert not problems, "\n".join(problems)


def test_the_stubs_are_valid_python_and_beside_the_module():
    assert os.path.exists(STUB), f"{STUB}: the build copies python/dsmplan.pyi beside the module"
    compile(open(STUB).read(), STUB, "exec")
