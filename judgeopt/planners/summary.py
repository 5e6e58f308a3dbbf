"""Results as a table a person reads at a glance: rows of plain values that print as aligned
text (`print(report.summary())`).

Why a list of dicts and not a DataFrame: pandas is no dependency of judgeopt, and a list of
dicts is what `pandas.DataFrame(report.summary())` takes where pandas is installed.
"""

from __future__ import annotations

from typing import Any, Sequence


def cell(value: Any) -> str:
    """One value as the text table shows it: "-" for None, floats to 4 significant digits."""
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


class SummaryTable(list[dict[str, Any]]):
    """Rows (dicts, one per result); `str()` is the aligned text table of every column."""

    @property
    def columns(self) -> list[str]:
        """Every key, in the order it first appears."""
        return list(dict.fromkeys(k for row in self for k in row))

    def text(self, columns: Sequence[str] | None = None) -> str:
        """The rows as aligned text, under a header and a rule; `columns`: which, in this order."""
        names = list(self.columns if columns is None else columns)
        cells = [names] + [[cell(row.get(c)) for c in names] for row in self]
        widths = [max(len(r[i]) for r in cells) for i in range(len(names))]
        lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
        lines.insert(1, "  ".join("-" * w for w in widths))
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.text()
