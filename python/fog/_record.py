"""A command's JSON as a Python object: its fields as attributes, nested objects as records of
their own classes (generated in `fog.records`)."""

from __future__ import annotations

from typing import Any, ClassVar


class Record:
    """A command's result with its JSON fields as attributes (nested ones too); `to_dict()` gives
    the plain JSON back. Each contract and each object in it has a class of its own in
    `fog.records`, its fields annotated and documented."""

    _nested: ClassVar[dict[str, type[Record] | tuple[type[Record], ...]]] = {}
    """The class each nested object field is read as (the items' class, for a list); for a field
    that may hold either of several, their tuple, of which the one whose fields the object's are
    is taken."""

    def __init__(self, fields: dict[str, Any]):
        self._fields = fields

    def __getattr__(self, name: str) -> Any:
        try:
            value = self._fields[name]
        except KeyError:
            raise AttributeError(
                f"{name!r}: no such field (fields: {', '.join(self._fields)})"
            ) from None
        return _wrap(value, type(self)._nested.get(name, Record))

    def __dir__(self) -> list[str]:
        return list(self._fields)

    def to_dict(self) -> dict[str, Any]:
        """The fields as the command's `--json` writes them."""
        return self._fields

    def to_frame(self) -> Any:
        """The record's table as a pandas DataFrame (pandas must be installed): its list fields
        of numbers that share the longest length as columns (`tau_s`, `adev_dps`, … of an Allan
        analysis), or, where its fields are records in a list (`channels` of a fit's report), one
        row per record of their numbers and words."""
        import pandas as pd

        lists = {k: v for k, v in self._fields.items() if isinstance(v, list) and v}
        rows = [v for v in lists.values() if all(isinstance(x, dict) for x in v)]
        if rows:
            return pd.DataFrame(
                [{k: x for k, x in r.items() if not isinstance(x, (dict, list))} for r in rows[0]]
            )
        numeric = {
            k: v for k, v in lists.items()
            if all(isinstance(x, (int, float)) or x is None for x in v)
        }
        if not numeric:
            raise ValueError("this record holds no table")
        longest = max(len(v) for v in numeric.values())
        return pd.DataFrame({k: v for k, v in numeric.items() if len(v) == longest})

    def __repr__(self) -> str:
        shown = ", ".join(f"{k}={_short(v)}" for k, v in self._fields.items())
        return f"{type(self).__name__}({shown})"


def _wrap(value: Any, cls: type[Record] | tuple[type[Record], ...]) -> Any:
    if isinstance(value, dict):
        return _class_of(value, cls)(value)
    if isinstance(value, list):
        return [_wrap(v, cls) for v in value]
    return value


def _class_of(value: dict[str, Any], cls: type[Record] | tuple[type[Record], ...]) -> type[Record]:
    """`cls`, or of several the one that names every field of `value` and leaves fewest of its own
    out (each class's fields are its annotations)."""
    if not isinstance(cls, tuple):
        return cls
    keys = set(value)

    def fields(c: type[Record]) -> set[str]:
        return {name for k in c.__mro__ for name in getattr(k, "__annotations__", {})}

    return min(cls, key=lambda c: (not keys <= fields(c), len(fields(c) - keys)))


def _short(value: Any) -> str:
    if isinstance(value, list) and len(value) > 4:
        return f"[{len(value)} values]"
    if isinstance(value, dict):
        return "{…}"
    return repr(value)
