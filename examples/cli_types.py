"""argparse types shared by the example scripts: numbers and whole numbers in a range, with messages that name
the value, the allowed range and the unit."""
import argparse
import math


def number_parser(unit: str, low: float = 0.0, high: float = math.inf, low_inclusive: bool = False):
    """argparse type: a finite number in (low, high] (or [low, high])."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number (in {unit})") from None
        above = value >= low if low_inclusive else value > low
        if not (math.isfinite(value) and above and value <= high):
            allowed = (f"{'>=' if low_inclusive else '>'} {low:g}" if high == math.inf
                       else f"{'[' if low_inclusive else '('}{low:g}, {high:g}]")
            raise argparse.ArgumentTypeError(f"{text} {unit} is out of range: allowed {allowed} {unit}".rstrip())
        return value
    return parse


def whole_number_parser(minimum: int, why: str = ""):
    """argparse type: a whole number >= minimum (`why` explains the bound in the message)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} is invalid: allowed a whole number >= {minimum}"
                                             + (f" ({why})" if why else ""))
        return value
    return parse
