"""Loaned interfaces: a controller's direct handle on one interface value.

Counterpart: ``hardware_interface::LoanedStateInterface`` / ``LoanedCommandInterface``. A loan
is an (array, index) pair into the float64 array the resource manager allocated once, so
``get_value()`` / ``set_value()`` touch the hardware's own memory: no copy, no lookup, no new
array. :class:`InterfaceGroup` turns several loans into one vector operation: a numpy slice
view when their slots are contiguous, an index array otherwise. Releasing a command loan
frees the claim (upstream does it in the destructor; here ``release()``, called by the
controller manager on deactivation).
"""

from __future__ import annotations

import numpy as np


class LoanedStateInterface:
    """Read access to one state interface (``get_value``); shared by any number of controllers."""

    __slots__ = ("name", "array", "index", "_release")

    def __init__(self, name: str, array: np.ndarray, index: int, release=None):
        self.name = name
        self.array = array
        self.index = index
        self._release = release

    def get_name(self) -> str:
        return self.name

    def get_prefix_name(self) -> str:
        return self.name.rpartition("/")[0]

    def get_interface_name(self) -> str:
        return self.name.rpartition("/")[2]

    def get_value(self) -> float:
        return self.array[self.index]

    get_optional = get_value

    def release(self) -> None:
        if self._release is not None:
            self._release(self.name)
            self._release = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, value={float(self.array[self.index])!r})"


class LoanedCommandInterface(LoanedStateInterface):
    """Exclusive write access to one command interface (``set_value``)."""

    __slots__ = ()

    def set_value(self, value: float) -> bool:
        self.array[self.index] = value
        return True


class InterfaceGroup:
    """Vector access to several loans: ``group.get()`` -> values, ``group.set(values)``.

    ``get(out=buffer)`` fills a caller-owned buffer; ``view`` is the live numpy slice when
    the loans sit in consecutive slots of one array (else None).
    """

    def __init__(self, loans):
        self.loans = list(loans)
        self.names = [loan.name for loan in self.loans]
        arrays = {id(loan.array) for loan in self.loans}
        self.array = self.loans[0].array if len(arrays) == 1 and self.loans else None
        idx = np.array([loan.index for loan in self.loans], dtype=np.intp)
        self.index = idx
        contiguous = (self.array is not None and len(idx) > 0
                      and bool(np.all(np.diff(idx) == 1)))
        self.view = self.array[idx[0]:idx[0] + len(idx)] if contiguous else None

    def __len__(self) -> int:
        return len(self.loans)

    def get(self, out: np.ndarray | None = None) -> np.ndarray:
        if out is None:
            out = np.empty(len(self.loans))
        if self.view is not None:
            out[:] = self.view
        elif self.array is not None:
            np.take(self.array, self.index, out=out, mode="clip")   # mode='raise' would buffer out= anew
        else:
            for k, loan in enumerate(self.loans):
                out[k] = loan.array[loan.index]
        return out

    def set(self, values) -> None:
        if self.view is not None:
            self.view[:] = values
        elif self.array is not None:
            self.array[self.index] = values
        else:
            for k, loan in enumerate(self.loans):
                loan.array[loan.index] = values[k]
