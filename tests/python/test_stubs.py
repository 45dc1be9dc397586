"""The type stubs (python/rangeseg.pyi) against the module: the same public names, and per
function and method the same parameters in the same order as the bindings' signatures."""

import ast
import os
import unittest

import rangeseg

SOURCE_DIR = os.environ.get("RANGESEG_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
STUB = os.path.join(SOURCE_DIR, "python", "rangeseg.pyi")


def split_top_level(text):
    """Splits at commas outside brackets."""
    parts, depth, start = [], 0, 0
    for i, c in enumerate(text):
        if c in "[(":
            depth += 1
        elif c in "])":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p.strip() for p in parts if p.strip()]


def bound_parameters(obj):
    """Parameter names (and '*') of a pybind11 function from its signature line, without self."""
    line = obj.__doc__.lstrip().split("\n", 1)[0]
    inside = line[line.index("(") + 1 : line.rindex(")")]
    names = [p.split(":")[0].split("=")[0].strip() for p in split_top_level(inside)]
    return [n for n in names if n != "self"]


def stub_parameters(node):
    args = node.args
    names = [a.arg for a in args.posonlyargs + args.args if a.arg != "self"]
    if args.kwonlyargs:
        names.append("*")
        names += [a.arg for a in args.kwonlyargs]
    return names


def public(names):
    return {n for n in names if not n.startswith("_")}


class StubTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with open(STUB, encoding="utf-8") as f:
            cls.tree = ast.parse(f.read(), STUB)
        cls.functions = {n.name: n for n in cls.tree.body if isinstance(n, ast.FunctionDef)}
        cls.classes = {n.name: n for n in cls.tree.body if isinstance(n, ast.ClassDef)}

    def test_module_names(self):
        module = {n for n in public(dir(rangeseg)) if not isinstance(getattr(rangeseg, n), type(os))}
        self.assertEqual(module, set(self.functions) | set(self.classes))

    def test_function_parameters(self):
        for name, node in self.functions.items():
            with self.subTest(function=name):
                self.assertEqual(stub_parameters(node), bound_parameters(getattr(rangeseg, name)))

    def test_class_members_and_parameters(self):
        for name, node in self.classes.items():
            cls = getattr(rangeseg, name)
            members = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
            with self.subTest(cls=name):
                self.assertEqual(public(members), public(vars(cls)))
            for member, fn in members.items():
                attribute = vars(cls).get(member)
                if isinstance(attribute, property) or attribute is None:
                    continue
                with self.subTest(method=f"{name}.{member}"):
                    self.assertEqual(stub_parameters(fn), bound_parameters(attribute))


if __name__ == "__main__":
    unittest.main()
