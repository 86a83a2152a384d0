#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""python/ehpt.pyi names exactly the module's public names with the module's signatures, and
every public function, class, method and property has a docstring (help(ehpt.run) explains
every argument and the result).

The module's own signatures are the first line of each pybind11 docstring ("run(scenario: str
| os.PathLike[str], ...) -> ehpt.RunResult"), written by pybind11 from the bindings' argument
names, defaults and declared types; they are parsed as Python and compared with the stub's
function definitions: parameter names and order, annotations and defaults as text, return
annotations. The message classes' stub __init__ must list their _fields as keyword-only
parameters whose defaults equal a default-constructed message's fields. The stub read is the
one next to the module (where the build puts it and the install rule installs it)."""

import ast
import inspect
import os
import pydoc
import re
import unittest

import ehpt

MESSAGE_CLASSES = ("Stamp", "PsdSensors", "PsdCommand", "EvSensors", "EvCommand", "ShevSensors", "ShevCommand")
PYTHON_CLASSES = ("Problem", "Error")  # written in Python inside the module: inspect.signature works


def stub_path():
    return os.path.join(os.path.dirname(os.path.abspath(ehpt.__file__)), "ehpt.pyi")


def load_stub():
    with open(stub_path()) as f:
        return ast.parse(f.read())


def text(node):
    """An annotation or default as text, without the module prefix pybind11 writes ("ehpt.Stamp")."""
    return None if node is None else ast.unparse(node).replace("ehpt.", "")


def pybind_signature(obj):
    """The first docstring line of a pybind11 function, parsed: ast.FunctionDef."""
    first = obj.__doc__.splitlines()[0]
    head, _, ret = first.rpartition(" -> ")
    params = head[head.index("(") + 1:head.rindex(")")]
    return ast.parse(f"def f({params}) -> {ret}: pass").body[0]


def params(fn):
    """[(name, annotation, default)] of an ast function, self left out."""
    a = fn.args
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + list(a.defaults)
    out = [(p.arg, text(p.annotation), text(d), "positional") for p, d in zip(positional, defaults)]
    out += [(p.arg, text(p.annotation), text(d), "keyword") for p, d in zip(a.kwonlyargs, a.kw_defaults)]
    if a.kwarg:
        out.append(("**" + a.kwarg.arg, None, None, "kwargs"))
    return [p for p in out if p[0] not in ("self", "arg0")]


def stub_members(cls_node):
    """{name: node} of a stub class body (functions, properties, annotated attributes)."""
    out = {}
    for n in cls_node.body:
        if isinstance(n, ast.FunctionDef):
            out[n.name] = n
        elif isinstance(n, ast.AnnAssign):
            out[n.target.id] = n
    return out


def is_property(fn):
    return isinstance(fn, ast.FunctionDef) and any(isinstance(d, ast.Name) and d.id == "property" for d in fn.decorator_list)


class StubNamesTheModule(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.stub = load_stub()
        cls.top = {}
        for n in cls.stub.body:
            if isinstance(n, (ast.FunctionDef, ast.ClassDef)):
                cls.top[n.name] = n
            elif isinstance(n, ast.AnnAssign):
                cls.top[n.target.id] = n

    def test_the_stub_is_next_to_the_module(self):
        self.assertTrue(os.path.isfile(stub_path()), stub_path())

    def test_public_names(self):
        module = sorted(n for n in dir(ehpt) if not n.startswith("_"))
        stub = sorted(n for n in self.top if not n.startswith("_"))
        self.assertEqual(stub, module, "names in python/ehpt.pyi vs dir(ehpt)")
        self.assertGreaterEqual(len(module), 10)

    def test_version(self):
        self.assertEqual(text(self.top["__version__"].annotation), "str")
        self.assertIsInstance(ehpt.__version__, str)
        # the build's version, the one summary.json names
        r = ehpt.run("ev_nedc", set={"solver.duration_s": 1})
        self.assertEqual(ehpt.__version__, r.summary["provenance"]["ehpt_version"])
        self.assertRegex(ehpt.__version__, r"^\d+\.\d+\.\d+$")

    def test_run(self):
        self.compare_function(ehpt.run, self.top["run"], "run")

    def compare_function(self, obj, stub_fn, what):
        got = pybind_signature(obj)
        self.assertEqual(params(stub_fn), params(got), f"{what}: parameters (name, annotation, default)")
        self.assertEqual(text(stub_fn.returns), text(got.returns), f"{what}: return annotation")

    def test_bound_classes(self):
        checked = 0
        for name, node in self.top.items():
            if not isinstance(node, ast.ClassDef) or name in MESSAGE_CLASSES + PYTHON_CLASSES:
                continue
            cls = getattr(ehpt, name)
            members = stub_members(node)
            module_members = sorted(n for n in vars(cls) if not n.startswith("_"))
            self.assertEqual(sorted(n for n in members if not n.startswith("_")), module_members, f"{name}: members")
            for m, fn in members.items():
                what = f"{name}.{m}"
                attr = vars(cls)[m]
                if is_property(fn):
                    self.assertIsInstance(attr, property, what)
                    self.assertEqual(text(fn.returns), text(pybind_signature(attr.fget).returns), what)
                else:
                    self.assertNotIsInstance(attr, property, what)
                    self.compare_function(attr, fn, what)
                checked += 1
        self.assertGreater(checked, 25)

    def test_message_classes(self):
        for name in MESSAGE_CLASSES:
            cls, node = getattr(ehpt, name), self.top[name]
            members = stub_members(node)
            fields = [m for m, n in members.items() if isinstance(n, ast.AnnAssign)]
            self.assertEqual(tuple(fields), cls._fields, f"{name}: fields, in order")
            self.assertEqual(sorted(n for n in vars(cls) if not n.startswith("_")), sorted(fields), f"{name}: members")
            init = members["__init__"]
            self.assertEqual([p.arg for p in init.args.kwonlyargs], list(cls._fields), f"{name}.__init__: keyword-only fields")
            self.assertEqual([p.arg for p in init.args.args], ["self"])
            default = cls()
            for p, d in zip(init.args.kwonlyargs, init.args.kw_defaults):
                field = members[p.arg]
                self.assertEqual(text(p.annotation), text(field.annotation), f"{name}.{p.arg}: annotation")
                self.assertEqual(text(field.annotation), text(pybind_signature(vars(cls)[p.arg].fget).returns),
                                 f"{name}.{p.arg}: the module's type")
                want = eval(ast.unparse(d), vars(ehpt))  # the stub's default, as a value
                self.assertEqual(want, getattr(default, p.arg), f"{name}.{p.arg}: the stub's default is not {name}()'s")
                self.assertIs(type(want), type(getattr(default, p.arg)), f"{name}.{p.arg}: type of the default")

    def test_python_classes(self):
        for name in PYTHON_CLASSES:
            cls, node = getattr(ehpt, name), self.top[name]
            members = stub_members(node)
            sig = inspect.signature(cls.__init__)
            init = members["__init__"]
            a = init.args
            defaults = [None] * (len(a.args) - len(a.defaults)) + [ast.literal_eval(d) for d in a.defaults]
            got = [(p.name, None if p.default is inspect.Parameter.empty else p.default) for p in sig.parameters.values()]
            self.assertEqual([(p.arg, d) for p, d in zip(a.args, defaults)], got, f"{name}.__init__")
            attributes = sorted(m for m, n in members.items() if isinstance(n, ast.AnnAssign))
            instance = cls("x") if name == "Problem" else cls("x", [ehpt.Problem("x")])
            module_attributes = sorted(instance.__slots__ if name == "Problem" else vars(instance))
            self.assertEqual(attributes, module_attributes, f"{name}: attributes")
        self.assertTrue(issubclass(ehpt.Error, ValueError))
        self.assertEqual([b.id for b in self.top["Error"].bases], ["ValueError"])


class Docstrings(unittest.TestCase):
    def public_objects(self):
        for name in dir(ehpt):
            if name.startswith("_"):
                continue
            obj = getattr(ehpt, name)
            yield name, obj.__doc__
            if inspect.isclass(obj):
                slots = vars(obj).get("__slots__")
                for m, attr in vars(obj).items():
                    if not m.startswith("_") or m == "__init__":
                        # a slot's docstring is the value of __slots__ = {name: doc} (what help() shows)
                        yield f"{name}.{m}", slots[m] if isinstance(slots, dict) and m in slots else attr.__doc__

    def test_everything_has_a_docstring(self):
        count = 0
        for name, doc in self.public_objects():
            doc = doc or ""
            lines = doc.strip().splitlines()
            # pybind11 puts the signature first: something must follow it
            if lines and re.match(r"^\w*\(.*\) -> \S", lines[0]):
                lines = lines[1:]
            self.assertTrue(any(l.strip() for l in lines), f"{name} has no docstring")
            count += 1
        self.assertGreater(count, 70)

    def arguments_section(self, doc):
        self.assertIn("Arguments:", doc)
        section = doc.split("Arguments:", 1)[1].split("\n\n", 1)[0]
        return [l.split()[0] for l in section.splitlines() if l.startswith("  ") and not l.startswith("   ")]

    def test_help_run_explains_every_argument_and_the_result(self):
        help_text = pydoc.render_doc(ehpt.run, renderer=pydoc.plaintext)
        names = [p[0] for p in params(pybind_signature(ehpt.run))]
        self.assertEqual(names, ["scenario", "set", "cycle", "faults"])
        self.assertEqual(self.arguments_section(ehpt.run.__doc__), names)
        for n in names:
            self.assertIn("  " + n + "  ", help_text)
        self.assertIn("Returns:", help_text)
        self.assertIn("RunResult", help_text.split("Returns:", 1)[1])
        self.assertIn("ehpt.Error", help_text)

    def test_simulation_explains_every_argument(self):
        names = [p[0] for p in params(pybind_signature(ehpt.Simulation.__init__))]
        self.assertEqual(self.arguments_section(ehpt.Simulation.__init__.__doc__), names)
        self.assertIn("Raises:", ehpt.Simulation.__init__.__doc__)


if __name__ == "__main__":
    unittest.main()
