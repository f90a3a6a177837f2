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


_PLAIN_TYPES = {
    float: lambda data: isinstance(data, (int, float)) and not isinstance(data, bool),
    int: lambda data: isinstance(data, int) and not isinstance(data, bool),
    bool: lambda data: isinstance(data, bool),
    str: lambda data: isinstance(data, str),
}
"""What a YAML value of each plain type may be (a bool is no number)."""


def check_schema(schema, data, where: str):
    """Check raw YAML ``data`` against the type ``schema`` (a dataclass, a list, a mapping, a tagged union
    or a plain type); ScenarioError naming the key path below ``where``."""
    origin = typing.get_origin(schema)
    if origin in (typing.Union, types.UnionType):
        _check_union(typing.get_args(schema), data, where)
    elif origin is list:
        _check_list(typing.get_args(schema)[0], data, where)
    elif origin is dict:
        _check_mapping(typing.get_args(schema)[1], data, where)
    elif dc.is_dataclass(schema):
        _check_dataclass(schema, data, where)
    elif not _PLAIN_TYPES.get(schema, lambda data: True)(data):
        raise ScenarioError(f"{where}: expected {type_name(schema)}, got {data!r}")


def _check_union(args, data, where: str):
    """An optional type (None allowed) or a union told apart by the mapping's type tag (``!Straight``)."""
    if data is None and type(None) in args:
        return
    options = [a for a in args if a is not type(None)]
    if len(options) == 1:
        return check_schema(options[0], data, where)
    tags = ", ".join("!" + type_name(a) for a in options)
    if not isinstance(data, dict) or "_tag" not in data:
        raise ScenarioError(f"{where}: needs a type tag, one of {tags}")
    tag = data["_tag"].lstrip("!")
    for option in options:
        if type_name(option) == tag:
            return check_schema(option, {k: v for k, v in data.items() if k != "_tag"}, where)
    raise ScenarioError(f"{where}: type tag !{tag} is unknown: allowed {tags}")


def _check_list(item_type, data, where: str):
    if not isinstance(data, list):
        raise ScenarioError(f"{where}: expected a list, got {data!r}")
    for i, item in enumerate(data):
        check_schema(item_type, item, f"{where}[{i}]")


def _check_mapping(value_type, data, where: str):
    if not isinstance(data, dict):
        raise ScenarioError(f"{where}: expected a mapping, got {data!r}")
    for key, value in data.items():
        check_schema(value_type, value, f"{where}.{key}")


def _check_dataclass(schema, data, where: str):
    """Every key a field of ``schema`` (the type tag aside), each value checked against its field's type."""
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
