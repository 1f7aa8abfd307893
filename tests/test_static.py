"""Compile-time options (pardem/core/static.py): every set of options is its own specialisation."""

import numba as nb
import pytest

from pardem.contact.model import ContactOptions
from pardem.core.static import Static, static
from pardem.core.step import StepOptions


@nb.njit
def _switches(opts):
    c = opts.contact
    return (1 if c.tangential_damping else 0) + (2 if c.rolling else 0) + (4 if opts.walls else 0)


def test_option_sets_of_one_shape_get_their_own_specialisations():
    """numba's dispatcher recognises a tuple argument by its items' types alone: were the
    options a NamedTuple of bools, the second call would reuse the first specialisation."""
    plain = StepOptions()
    damped = plain._replace(contact=ContactOptions(tangential_damping=True))
    rolling = plain._replace(contact=ContactOptions(rolling=True), walls=False)
    assert [_switches(o) for o in (plain, damped, rolling, plain)] == [4, 5, 2, 4]
    assert len(_switches.signatures) == 3
    assert all(isinstance(sig[0], Static) for sig in _switches.signatures)


def test_options_are_hashable_values_with_the_named_tuple_spelling():
    a = ContactOptions()
    assert a == ContactOptions() and hash(a) == hash(ContactOptions())
    assert a._replace(eta=True) != a and a._replace(eta=True).eta
    assert a._fields[:2] == ("damping", "friction")
    with pytest.raises(Exception):
        a.eta = True  # frozen: an option set is a compile-time constant


def test_a_field_that_cannot_be_a_constant_is_refused_by_name():
    @static
    class Bad:
        scale: float = 0.5

    @nb.njit
    def read(o):
        return o.scale

    with pytest.raises(Exception, match="bools, ints or @static values, not float"):
        read(Bad())
