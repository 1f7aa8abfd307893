"""Compile-time options: option sets whose values are part of their numba type.

numba types a NamedTuple of switches as a tuple of run-time booleans, so a kernel taking one
would compile every effect in and test the switches at run time. A class marked ``@static``
(a frozen dataclass that keeps the NamedTuple spelling) is typed instead as ``Static(value)``:
each field reads in compiled code as a literal constant (bool or int; a nested ``@static``
value stays static), so every option set is its own specialisation of an ordinary cached
kernel, and LLVM removes the branches of the effects that are off. The value carries no data
at run time.

This lets a large kernel take the options as an argument instead of being inlined into the
step loop at numba IR level (``inline="always"`` copies the callee's IR into the caller, which
cost ~20 s of the cold compile for the force loop alone;
``run_scripts/benchmarks/compile_times.py``).
"""

from __future__ import annotations

import dataclasses

from numba.core import types
from numba.core.typing.templates import AttributeTemplate
from numba.core.imputils import lower_constant
from numba.extending import (NativeValue, infer_getattr, lower_getattr_generic,
                             models, register_model, typeof_impl, unbox)


class Static(types.Type):
    """The numba type of one value of a ``@static`` class."""

    classes: tuple = ()

    def __init__(self, value):
        self.value = value
        super().__init__(name=f"Static[{type(value).__module__}.{value!r}]")


def _field_type(value):
    if isinstance(value, Static.classes):
        return Static(value)
    if isinstance(value, (bool, int)):
        return types.literal(value)
    raise TypeError(f"a @static class holds bools, ints or @static values, not "
                    f"{type(value).__name__} ({value!r})")


def _replace(self, **changes):
    return dataclasses.replace(self, **changes)


def static(cls):
    """Class decorator: ``cls`` (annotated fields with defaults) becomes a frozen dataclass
    whose values are compile-time constants in compiled code. It keeps the NamedTuple
    spelling (``_fields``, ``_replace``) but is no tuple: numba's dispatcher recognises a
    tuple argument by its items' types alone, so two option sets of the same shape would
    share one compiled specialisation."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    cls._fields = tuple(f.name for f in dataclasses.fields(cls))
    cls._replace = _replace
    Static.classes = Static.classes + (cls,)
    typeof_impl.register(cls)(lambda value, context: Static(value))
    return cls


register_model(Static)(models.OpaqueModel)


@infer_getattr
class _StaticFields(AttributeTemplate):
    key = Static

    def generic_resolve(self, typ, attr):
        if attr in typ.value._fields:
            return _field_type(getattr(typ.value, attr))
        return None


@lower_getattr_generic(Static)
def _read_field(context, builder, typ, value, attr):
    field = getattr(typ.value, attr)
    if isinstance(field, Static.classes):
        return context.get_constant_null(Static(field))
    return context.get_constant(types.unliteral(_field_type(field)), field)


@lower_constant(Static)
def _constant(context, builder, typ, value):
    return context.get_constant_null(typ)


@unbox(Static)
def _unbox(typ, obj, c):
    return NativeValue(c.context.get_constant_null(typ))
