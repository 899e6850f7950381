"""What every server that can move a robot or spend a GPU asks of its clients: a token of real strength off
this machine, and patience from a peer that keeps sending wrong ones.

The robot bridge, the model server and the demo share these rules (the bridge keeps them here because the
robot's computer imports nothing of attribot but `attribot.bridge`: Python 3.8, standard library only).

- `token_problem(token)`: why a token is too weak to guard a port other machines reach (None: strong
  enough): at least `MIN_TOKEN_CHARS` characters, more than one kind of character (lower case, upper case,
  digits, others), not a few characters repeated, no obvious word ("password", "secret", ...).
- `bind_problem(host, token)`: the same, for a server about to listen on `host`: on loopback any token that
  is not blank (or none at all) will do; beyond it a strong one is needed.
- `WrongTokens`: per peer address, wrong tokens past the first `free` ones are answered more and more
  slowly, and past `block_after` within `window_s` the address is refused outright for `block_s`. Each
  peer costs at most one log line per window however many tokens it tries, plus one when it is blocked.
"""

from __future__ import annotations

import ipaddress
import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable

__all__ = [
    "MIN_TOKEN_CHARS",
    "OBVIOUS_WORDS",
    "TOKEN_FIX",
    "token_problem",
    "is_loopback",
    "bind_problem",
    "WrongTokens",
]

MIN_TOKEN_CHARS = 16
"""The shortest token a server takes to listen beyond this machine."""
MIN_DISTINCT_CHARS = 6
"""The fewest different characters such a token holds ("abababababababab" is no secret)."""
OBVIOUS_WORDS = (
    "password",
    "passw0rd",
    "secret",
    "changeme",
    "letmein",
    "admin",
    "qwerty",
    "welcome",
    "default",
    "token",
    "attribot",
    "robomaster",
    "test",
    "123456",
    "abcdef",
)
"""Words a token may not contain: the first ones anyone guessing tries."""
TOKEN_FIX = "make one with: python3 -c 'import secrets; print(secrets.token_hex(16))'"


def token_problem(token: str | None) -> str | None:
    """Why `token` is too weak to guard a port that other machines reach, or None when it is strong enough."""
    if token is None or not token.strip():
        return "is blank"
    if len(token) < MIN_TOKEN_CHARS:
        return "is {} character{} long; at least {} are needed".format(
            len(token), "" if len(token) == 1 else "s", MIN_TOKEN_CHARS
        )
    kinds = {
        "lower" if c.islower() else "upper" if c.isupper() else "digit" if c.isdigit() else "other"
        for c in token
    }
    if len(kinds) < 2:
        return "uses one kind of character only (mix letters with digits or other characters)"
    if len(set(token)) < MIN_DISTINCT_CHARS:
        return f"repeats {len(set(token))} different characters; at least {MIN_DISTINCT_CHARS} are needed"
    lowered = token.lower()
    for word in OBVIOUS_WORDS:
        if word in lowered:
            return f"contains {word!r}, one of the first words anyone guessing tries"
    return None


def is_loopback(host: str) -> bool:
    """Whether listening on `host` stays on this machine (localhost, 127.0.0.0/8, ::1)."""
    name = host.strip().strip("[]").lower()
    if name == "localhost":
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def bind_problem(host: str, token: str | None) -> str | None:
    """What is wrong with listening on `host` guarded by `token` (None: nothing). A token given is never
    blank; beyond loopback one is needed, and it must be strong (`token_problem`)."""
    if token is not None and not token.strip():
        return "the token is blank"
    if is_loopback(host):
        return None
    if token is None:
        return f"the server would listen on {host} without a token"
    weak = token_problem(token)
    if weak is not None:
        return f"the token {weak} (it guards {host}, which other machines reach)"
    return None


class WrongTokens:
    """Wrong tokens per peer address: slowed past `free`, blocked for `block_s` past `block_after` within
    `window_s`; bounded in memory (`max_peers`, the stalest forgotten first) and in log lines.

    Thread-safe. `blocked(peer)` is what every request pays: a dict lookup, and nothing at all while no
    peer has sent a wrong token."""

    def __init__(
        self,
        free: int = 3,
        block_after: int = 20,
        window_s: float = 60.0,
        block_s: float = 300.0,
        max_delay_s: float = 2.0,
        max_peers: int = 4096,
        log: logging.Logger | None = None,
        what: str = "server",
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if not (0 <= free < block_after):
            raise ValueError("WrongTokens needs 0 <= free < block_after")
        self.free = free
        self.block_after = block_after
        self.window_s = window_s
        self.block_s = block_s
        self.max_delay_s = max_delay_s
        self.max_peers = max_peers
        self.log = log or logging.getLogger("attribot.guard")
        self.what = what
        self.clock = clock
        self._lock = threading.Lock()
        # peer -> [window start, wrong tokens in it, blocked until, refused while blocked]
        self._peers = OrderedDict()  # type: OrderedDict[str, list[float]]

    BLOCKED_WAIT_S = 0.5
    """How long a blocked peer waits for its refusal: a blocked address is not answered at full speed."""

    def blocked(self, peer: str) -> float:
        """Seconds left of `peer`'s block (0: not blocked). A blocked peer's attempts are counted, not
        logged."""
        if not self._peers:  # the common case: nobody has sent a wrong token
            return 0.0
        with self._lock:
            entry = self._peers.get(peer)
            if entry is None:
                return 0.0
            left = entry[2] - self.clock()
            if left <= 0:
                return 0.0
            entry[3] += 1
            return left

    def wrong(self, peer: str) -> float:
        """Count one wrong token from `peer`; the seconds to wait before answering it."""
        now = self.clock()
        line = None
        with self._lock:
            entry = self._peers.get(peer)
            if entry is None:
                while len(self._peers) >= self.max_peers:
                    self._peers.popitem(last=False)
                entry = self._peers[peer] = [now, 0.0, 0.0, 0.0]
            else:
                self._peers.move_to_end(peer)
            if now - entry[0] > self.window_s and now >= entry[2]:
                if entry[1] > 1:
                    line = (
                        f"{self.what}: {int(entry[1])} wrong tokens from {peer} "
                        f"in the last {now - entry[0]:.0f} s"
                    )
                entry[0], entry[1], entry[3] = now, 0.0, 0.0
            entry[1] += 1
            count = int(entry[1])
            if count == 1 and line is None:
                line = (
                    f"{self.what}: refused {peer}: wrong token "
                    f"(more from it within {self.window_s:.0f} s are counted, not logged)"
                )
            if count == self.block_after:
                entry[2] = now + self.block_s
                line = (
                    f"{self.what}: blocking {peer} for {self.block_s:.0f} s "
                    f"after {count} wrong tokens within {self.window_s:.0f} s"
                )
        if line is not None:
            self.log.warning("%s", line)
        if count <= self.free:
            return 0.0
        return min(self.max_delay_s, 0.1 * 2.0 ** min(count - self.free - 1, 30))

    def right(self, peer: str) -> None:
        """A right token from `peer`: its count of wrong ones starts again (a block still holds)."""
        if not self._peers:
            return
        with self._lock:
            entry = self._peers.get(peer)
            if entry is not None and self.clock() >= entry[2]:
                del self._peers[peer]

    def counts(self) -> dict:
        """peer -> wrong tokens in its current window (for tests and metrics)."""
        with self._lock:
            return {peer: int(entry[1]) for peer, entry in self._peers.items()}
