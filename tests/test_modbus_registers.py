"""The Modbus register codec, checked against hand-computed register words."""

from __future__ import annotations

import math

import pytest

from drivers import CodecError
from drivers.modbus.errors import DeviceBusy, IllegalDataAddress, ModbusExceptionResponse, exception_response
from drivers.modbus.registers import InputPoint, RegisterPoint, overlap


def point(**kw):
    return RegisterPoint(address=kw.pop("address", 10), **kw)


@pytest.mark.parametrize(
    "kw, value, words",
    [
        ({"type": "float32"}, 1.25, [0x3FA0, 0x0000]),  # 1.25 = 0x3FA00000
        ({"type": "float32"}, -2.5, [0xC020, 0x0000]),
        ({"type": "float32", "word_order": "little"}, 1.25, [0x0000, 0x3FA0]),
        ({"type": "float64"}, 1.0, [0x3FF0, 0, 0, 0]),
        ({"type": "int16", "scale": 1000.0}, -1.5, [0xFA24]),  # -1500 in two's complement
        ({"type": "uint16", "scale": 100.0}, 6.0, [0x0258]),  # 600
        ({"type": "int32", "scale": 1e6}, 1.25, [0x0013, 0x12D0]),  # 1250000
        ({"type": "int32", "scale": 1e6, "word_order": "little"}, 1.25, [0x12D0, 0x0013]),
        ({"type": "uint32", "scale": 1.0}, 70000.0, [0x0001, 0x1170]),
    ],
)
def test_encode_gives_the_hand_computed_words_and_decodes_back(kw, value, words):
    p = point(**kw)
    assert p.encode(value) == words
    assert p.decode(words) == pytest.approx(value, rel=0, abs=p.resolution or 1e-12)
    assert p.count == len(words)


def test_scaled_integers_round_to_the_resolution():
    p = point(type="int16", scale=1000.0)
    assert p.resolution == 0.001
    assert p.on_wire(1.23449) == pytest.approx(1.234)
    assert p.on_wire(1.2346) == pytest.approx(1.235)
    assert point(type="float32").resolution == 0.0


@pytest.mark.parametrize(
    "kw, value, fragment",
    [
        ({"type": "int16", "scale": 1000.0}, 40.0, "does not fit"),  # 40000 > 32767: never wrapped
        ({"type": "uint16", "scale": 1.0}, -1.0, "does not fit"),
        ({"type": "int16"}, math.nan, "cannot be stored"),
        ({"type": "int32"}, math.inf, "cannot be stored"),
        ({"type": "float32"}, 1e39, "overflows"),
    ],
)
def test_unrepresentable_values_are_refused(kw, value, fragment):
    with pytest.raises(CodecError, match=fragment):
        point(**kw).encode(value)


def test_float_registers_carry_nan_for_the_reader_to_reject():
    p = point(type="float32")
    assert math.isnan(p.decode(p.encode(math.nan)))


def test_decode_rejects_wrong_lengths_and_non_words():
    p = point(type="float32")
    with pytest.raises(CodecError, match="needs 2"):
        p.decode([1])
    with pytest.raises(CodecError, match="16-bit"):
        p.decode([1, 70000])


def test_points_past_the_address_space_and_overlaps():
    with pytest.raises(ValueError, match="65535"):
        RegisterPoint(address=65535, type="float32")
    a = RegisterPoint(address=0, type="float32")
    assert overlap(a, RegisterPoint(address=1))
    assert not overlap(a, RegisterPoint(address=2))
    assert not overlap(a, InputPoint(address=0))  # different tables
    assert InputPoint(address=3).table == "input"


def test_exception_codes_become_named_errors():
    err = exception_response(2, "reading the PSD")
    assert isinstance(err, IllegalDataAddress) and err.code == 2
    assert "Modbus exception 2" in str(err) and "register map" in str(err)
    assert isinstance(exception_response(6, "x"), DeviceBusy)
    unknown = exception_response(99, "x")
    assert type(unknown) is ModbusExceptionResponse and unknown.code == 99
