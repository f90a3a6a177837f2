"""Typed YAML data, strictly: the YAML text parsed (duplicate keys rejected, Drake's type tags kept, YAML
1.1 exponent floats read as numbers), checked against a dataclass schema (check_schema), and changed by
dotted key path (replaced_at: ``slipnav sweep --set``). Every mistake raises ScenarioError naming the key
(e.g. ``trajectory.segments[2].length``)."""

import copy as _copy
import dataclasses as dc
import re
import types
import typing

import yaml


class ScenarioError(ValueError):
    """A scenario that cannot be loaded or built; the message names the offending key."""


def type_name(t) -> str:
    """A type's name as the messages and the YAML type tags write it."""
    return getattr(t, "__name__", str(t))


def check_schema(schema, data, where: str):
    """Check raw YAML ``data`` against the type ``schema`` (a dataclass, a list, a mapping, a tagged union
    or a plain type); ScenarioError naming the key path below ``where``."""
    origin = typing.get_origin(schema)
    args = typing.get_args(schema)
    if origin in (typing.Union, types.UnionType):
        if data is None and type(None) in args:
            return
        options = [a for a in args if a is not type(None)]
        if len(options) == 1:
            return check_schema(options[0], data, where)
        if not isinstance(data, dict) or "_tag" not in data:
            tags = ", ".join("!" + type_name(a) for a in options)
            raise ScenarioError(f"{where}: needs a type tag, one of {tags}")
        tag = data["_tag"].lstrip("!")
        for option in options:
            if type_name(option) == tag:
                return check_schema(option, {k: v for k, v in data.items() if k != "_tag"}, where)
        tags = ", ".join("!" + type_name(a) for a in options)
        raise ScenarioError(f"{where}: type tag !{tag} is unknown: allowed {tags}")
    if origin in (list, list):
        if not isinstance(data, list):
            raise ScenarioError(f"{where}: expected a list, got {data!r}")
        for i, item in enumerate(data):
            check_schema(args[0], item, f"{where}[{i}]")
        return
    if origin in (dict, dict):
        if not isinstance(data, dict):
            raise ScenarioError(f"{where}: expected a mapping, got {data!r}")
        for key, value in data.items():
            check_schema(args[1], value, f"{where}.{key}")
        return
    if dc.is_dataclass(schema):
        if not isinstance(data, dict):
            raise ScenarioError(f"{where or 'scenario'}: expected a mapping, got {data!r}")
        hints = typing.get_type_hints(schema)
        for key, value in data.items():
            path = f"{where}.{key}" if where else str(key)
            if key == "_tag":
                continue
            if key not in hints:
                raise ScenarioError(f"{path} is an unknown key: allowed {sorted(hints)}")
            check_schema(hints[key], value, path)
        return
    if schema is float:
        ok = isinstance(data, (int, float)) and not isinstance(data, bool)
    elif schema is int:
        ok = isinstance(data, int) and not isinstance(data, bool)
    elif schema is bool:
        ok = isinstance(data, bool)
    elif schema is str:
        ok = isinstance(data, str)
    else:
        ok = True
    if not ok:
        raise ScenarioError(f"{where}: expected {type_name(schema)}, got {data!r}")


class StrictLoader(yaml.SafeLoader):
    """SafeLoader with Drake's type tags (``!Straight {...}`` -> mapping with ``_tag``), an error on
    duplicate keys, and floats written without a dot or an exponent sign (``1e-8``, ``1.0e6``), which
    YAML 1.1 (PyYAML) would read as strings."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if key in seen:
                raise ScenarioError(
                    f"duplicate key {key!r} (lines {seen[key] + 1} and {key_node.start_mark.line + 1}): "
                    "allowed once per mapping"
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def _tagged(loader, tag, node):
    result = loader.construct_mapping(node)
    result["_tag"] = tag
    return result


StrictLoader.add_multi_constructor("", _tagged)
StrictLoader.yaml_implicit_resolvers = {
    first: list(resolvers) for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_yaml(text: str):
    """Parse YAML ``text`` with StrictLoader; ScenarioError for malformed YAML or a duplicate key."""
    try:
        return yaml.load(text, Loader=StrictLoader)
    except ScenarioError:
        raise
    except yaml.YAMLError as e:
        raise ScenarioError(f"malformed YAML: {' '.join(str(e).split())}") from None


KEY_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")


def parse_value(text: str):
    """A value as the scenario YAML reads it: ``0.05`` -> float, ``true`` -> bool, ``[0, 0, 1]`` -> list,
    ``bounded`` -> str."""
    return load_yaml(text)


def key_steps(key: str) -> list:
    """``trajectory.segments[1].length`` -> ['trajectory', 'segments', 1, 'length']."""
    steps = []
    for part in key.split("."):
        match = KEY_PART.match(part)
        if not match:
            raise ScenarioError(
                f"{key!r} is not a key path: allowed e.g. navigation.mixing.b1 or segments[1]"
            )
        steps.append(match.group(1))
        steps += [int(i) for i in re.findall(r"\[(\d+)\]", match.group(2))]
    return steps


def replaced_at(node, hint, steps: list, value, where: str):
    """``node`` (of declared type ``hint``) with the item at ``steps`` set to ``value``, type-checked."""
    if not steps:
        check_schema(hint, value, where)
        return as_declared(hint, value)
    step, rest = steps[0], steps[1:]
    if node is None:
        raise ScenarioError(f"{where} is not set in this scenario: it has no {step!r} to change")
    if isinstance(step, int):
        if not isinstance(node, list):
            raise ScenarioError(f"{where}[{step}]: {where} is not a list")
        if not 0 <= step < len(node):
            raise ScenarioError(f"{where}[{step}] is out of range: allowed index 0 .. {len(node) - 1}")
        item_hint = typing.get_args(hint)[0] if typing.get_origin(hint) is list else typing.Any
        if dc.is_dataclass(node[step]):
            item_hint = type(node[step])
        copy = list(node)
        copy[step] = replaced_at(node[step], item_hint, rest, value, f"{where}[{step}]")
        return copy
    path = f"{where}.{step}" if where else step
    if isinstance(node, dict):
        if rest:
            raise ScenarioError(f"{path}.{rest[0]}: {path} is a number, it has no keys")
        return {**node, step: replaced_at(None, typing.get_args(hint)[1], [], value, path)}
    if not dc.is_dataclass(node):
        raise ScenarioError(f"{path}: {where} is a single value, it has no keys")
    hints = typing.get_type_hints(type(node))
    if step not in hints:
        raise ScenarioError(f"{path} is an unknown key: allowed {sorted(hints)}")
    child = getattr(node, step)
    child_hint = type(child) if dc.is_dataclass(child) else hints[step]
    copy = _copy.copy(node)  # no __post_init__ here: validate() range-checks the whole scenario afterwards
    object.__setattr__(copy, step, replaced_at(child, child_hint, rest, value, path))
    return copy


def as_declared(hint, value):
    """``value`` (checked against ``hint``) with integers where floats are declared made floats."""
    union = typing.get_origin(hint) in (typing.Union, types.UnionType)
    options = [a for a in typing.get_args(hint) if a is not type(None)] if union else [hint]
    if float in options and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, list) and typing.get_origin(options[0]) is list:
        return [as_declared(typing.get_args(options[0])[0], v) for v in value]
    return value


def check_field_types(value, where: str) -> None:
    """Every field of a dataclass tree has its declared kind (a Python-built Scenario may hold None or
    a wrong object where the YAML schema would not allow it)."""
    hints = typing.get_type_hints(type(value))
    for field in dc.fields(value):
        item, path = getattr(value, field.name), f"{where}{field.name}"
        declared = hints[field.name]
        union = typing.get_origin(declared) in (typing.Union, types.UnionType)
        options = typing.get_args(declared) if union else (declared,)
        kinds = tuple(typing.get_origin(o) or o for o in options)
        if float in kinds:
            kinds += (int,)
        if not all(isinstance(k, type) for k in kinds):
            continue
        if not isinstance(item, kinds) or (isinstance(item, bool) and bool not in kinds):
            names = " or ".join("None" if k is type(None) else k.__name__ for k in kinds)
            raise ScenarioError(f"{path}={item!r}: expected {names}")
        if dc.is_dataclass(item):
            check_field_types(item, path + ".")
