"""A bounded memory of recent results, shared by the packages that keep some (serve, planners)."""

from __future__ import annotations

import collections
from typing import Any, Callable


class Recent(collections.OrderedDict):
    """The last `size` values by key, the least recently used dropped first: what the service keeps of
    the requests it prepared and the planners it loaded, and a joint map of the plans it checked."""

    def __init__(self, size: int):
        super().__init__()
        self.size = size

    def get_or_make(self, key: Any, make: Callable[[], Any]) -> Any:
        """The value kept for `key`, else make() kept (nothing is kept where make raises)."""
        if key not in self:
            self[key] = make()
            while len(self) > self.size:
                self.popitem(last=False)
        self.move_to_end(key)
        return self[key]
