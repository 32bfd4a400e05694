"""The studio's number fields: spin boxes that read what the user's locale types, and never a wrong number.

A ``QDoubleSpinBox`` reads and shows numbers in its locale (the system's, or ``QLocale.setDefault``): in
German or French "0,35" is 0.35. There, "." is the thousands separator, and a plain spin box reads "0.35"
as 35 — a silently wrong thickness or roughness when a number is pasted from a data sheet or typed on an
English habit. :class:`NumberField` reads a "." as the decimal point in a locale whose decimal point is
another character, except where the text is a number of that locale with its thousands separator
("1.234,5" and "1.500" are still 1234.5 and 1500 in German; "0.35" and "12.5" are not German numbers).
The field shows the locale's decimal point once the edit is done. The value (a float) is what the studio
saves: the same in every locale.
"""

from __future__ import annotations

import re
from typing import Any

from PySide6.QtGui import QValidator
from PySide6.QtWidgets import QDoubleSpinBox

#: A "." that is a thousands separator: between 1 to 3 digits (not a lone 0) and exactly 3 digits.
_THOUSANDS = re.compile(r"(?<![\d.])[1-9]\d{0,2}\.\d{3}(?![\d.])")

#: A number whose "." are all thousands separators (with the locale's decimal comma or not).
_GROUPED = re.compile(r"[+-]?[1-9]\d{0,2}(\.\d{3})+(,\d*)?")


class NumberField(QDoubleSpinBox):
    """A ``QDoubleSpinBox`` that also takes "." as the decimal point in a decimal-comma locale (see the module)."""

    def _in_locale(self, text: str) -> str:
        """``text`` with its one "." read as the decimal point where the locale's decimal point is not ".".

        Not where ``text`` is already a number of the locale ("1.234,5", "1.500" in German).
        """
        locale = self.locale()
        point = locale.decimalPoint()
        if point == "." or point in text or text.count(".") != 1:
            return text
        if locale.groupSeparator() == "." and _THOUSANDS.search(text):
            return text
        return text.replace(".", point)

    def validate(self, text: str, pos: int) -> Any:
        """Qt's validation of ``text`` read by :meth:`_in_locale`.

        The text stays as typed until the edit is done (so "1.5" can still become "1.500"); a "." that is
        neither a decimal point nor a thousands separator ("0.3.5") is refused.
        """
        read = self._in_locale(text)
        number = read.removeprefix(self.prefix()).removesuffix(self.suffix()).strip()
        if "." in number and self.locale().groupSeparator() == "." and not _GROUPED.fullmatch(number):
            return QValidator.State.Invalid, text, pos  # "0.3.5": not a number (Qt would read 35)
        result = super().validate(read, pos)
        state = result[0] if isinstance(result, tuple) else result
        return state, text, pos

    def valueFromText(self, text: str) -> float:
        """The value of ``text`` (a number of the locale, or one with "." as the decimal point)."""
        return super().valueFromText(self._in_locale(text))

