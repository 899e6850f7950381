"""The robot side of the bridge: one client at a time, authenticated, rate-limited, watched.

`RobotServer` serves a `Driver` (`driver.py`: the robot's own calls) over the protocol of `protocol.py`, one
request op at a time through the table of `requests.py`. Safety lives
here, not in the drivers, so that every robot gets it: the shared-secret token is checked before anything
moves (a wrong one is refused and logged), base velocities are clipped to the speed limits and ramped at
most at the acceleration limits, arm and head targets are clipped to the body's travel (a target far
outside it is refused), and a watchdog stops the base and the arm when no accepted command arrives within
`Limits.watchdog_s` or the connection drops. The robot stops on anything it refuses: a request it cannot
read, a value out of range, an unknown op, a call its driver failed. No message ends the server.
"""

from __future__ import annotations

import collections
import hmac
import logging
import math
import queue
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

from attribot.bridge.driver import Driver
from attribot.bridge.guard import TOKEN_FIX, WrongTokens, bind_problem
from attribot.bridge.protocol import (
    MAX_DEPTH,
    PROTOCOL_VERSION,
    ConnectionClosed,
    MessageError,
    ProtocolError,
    recv_message,
    send_message,
)
from attribot.bridge.requests import REQUESTS, Refused, shown

__all__ = ["Limits", "LIMIT_RANGES", "RobotServer", "serve_in_thread"]

log = logging.getLogger("attribot.bridge")


LIMIT_RANGES = {
    "max_speed": ("--max-speed", 0.01, 3.5, "m/s"),
    "max_turn": ("--max-turn", 0.01, 10.0, "rad/s"),
    "max_accel": ("--max-accel", 0.01, 10.0, "m/s^2"),
    "max_turn_accel": ("--max-turn-accel", 0.01, 30.0, "rad/s^2"),
    "watchdog_s": ("--watchdog", 0.05, 5.0, "s"),
}
"""Each limit's flag and its safe range (low, high, unit), both ends included: a RoboMaster EP drives at
most 3.5 m/s and turns at most 600 degrees/s; a watchdog of more than 5 s is no watchdog. A value outside
(a typo such as 1e9) is refused, never taken."""


class Limits:
    """Speed (m/s, rad/s) and acceleration (m/s^2, rad/s^2) limits of the base, and the watchdog time (s),
    each within its safe range (`LIMIT_RANGES`; a `ValueError` names the range of one outside it).

    `simulated`: a simulated robot (a test, a benchmark: nothing real moves) may take any positive limit,
    e.g. an acceleration of 1000 m/s^2 so that a step's velocity is the commanded one at once."""

    def __init__(
        self,
        max_speed: float = 0.5,
        max_turn: float = 1.5,
        max_accel: float = 2.0,
        max_turn_accel: float = 6.0,
        watchdog_s: float = 0.5,
        simulated: bool = False,
    ) -> None:
        for label, value in (
            ("max_speed", max_speed),
            ("max_turn", max_turn),
            ("max_accel", max_accel),
            ("max_turn_accel", max_turn_accel),
            ("watchdog_s", watchdog_s),
        ):
            flag, low, high, unit = LIMIT_RANGES[label]
            if simulated:
                low, high = 1e-9, 1e12
            number = value if isinstance(value, (int, float)) and not isinstance(value, bool) else None
            if number is None or not (math.isfinite(number) and low <= number <= high):
                raise ValueError(
                    f"{flag} must lie in its safe range, {low:g} to {high:g} {unit} (got {shown(value)})"
                )
        self.max_speed = float(max_speed)
        self.max_turn = float(max_turn)
        self.max_accel = float(max_accel)
        self.max_turn_accel = float(max_turn_accel)
        self.watchdog_s = float(watchdog_s)

    def as_dict(self) -> dict[str, float]:
        return dict(self.__dict__)


_RAMP_TICK = 0.02  # s: the ramp and the watchdog run at 50 Hz
HELLO_TIMEOUT_S = 2.0
"""How long a new connection has to send its hello: one that sends nothing must not hold the robot."""
MAX_GREETING = 16
"""Connections in their hello at once; more are closed at once (a flood must not exhaust threads)."""
MAX_GREETING_PER_ADDRESS = 4
"""Connections in their hello at once from one address: one flooding machine cannot take every slot."""
MAX_REQUEST_HEADER = 64 << 10
"""The largest request header the robot reads (the largest real one is under 200 bytes); requests carry no
payload."""
MESSAGE_TIMEOUT_S = 10.0
"""Once a request has begun, the rest of it must arrive within this time: one trickled a byte at a time
must not hold the robot."""


def _shut(conn: socket.socket) -> None:
    """End a connection's reads and writes (its reader then sees the connection closed)."""
    try:
        conn.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass


_LINGER_S = 1.0
_LINGER_BYTES = 4 << 20
_HELLO_FIX = "send hello with version and token first (docs/bridge-protocol.md)"
_READ_FIX = (
    f"send one JSON object per message: a header of at most {MAX_REQUEST_HEADER} bytes, nested at most "
    f"{MAX_DEPTH} deep, no payload (docs/bridge-protocol.md)"
)


def _answer(conn: socket.socket, refusal: Refused, last: bool = False) -> None:
    """Tell a client why it is refused, if it still listens. `last`: the connection ends here; what the
    client is still sending is read and dropped for a moment first, so that closing with unread bytes does
    not reset the connection before the client has read why."""
    try:
        send_message(conn, {"ok": False, "code": refusal.code, "error": refusal.message, "fix": refusal.fix})
        if last:
            conn.shutdown(socket.SHUT_WR)
            conn.settimeout(_LINGER_S)
            deadline = time.monotonic() + _LINGER_S
            dropped = 0
            while time.monotonic() < deadline and dropped < _LINGER_BYTES:
                chunk = conn.recv(1 << 16)
                if not chunk:
                    break
                dropped += len(chunk)
    except OSError:
        pass


def _keep_alive(conn: socket.socket) -> None:
    """Probe an idle client's connection, so that a planner's computer that vanished without closing it
    (power lost, network gone) frees the robot within about half a minute."""
    try:
        conn.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        for option, value in (("TCP_KEEPIDLE", 10), ("TCP_KEEPINTVL", 5), ("TCP_KEEPCNT", 3)):
            if hasattr(socket, option):  # Linux; elsewhere the system's defaults
                conn.setsockopt(socket.IPPROTO_TCP, getattr(socket, option), value)
    except OSError:
        pass


class RobotServer:
    """Serve `driver` on `host:port` to clients that know `token`; one client at a time.

    Beyond loopback the token must be strong (`attribot.bridge.guard.token_problem`; a `ValueError` says
    why not). `throttle`: wrong tokens from one address are answered more and more slowly and then that
    address is refused for a while (`guard.WrongTokens`, in `wrong_tokens`); off only to measure its cost."""

    RAMP_TICK = _RAMP_TICK

    def __init__(
        self,
        driver: Driver,
        token: str,
        host: str = "127.0.0.1",
        port: int = 0,
        limits: Limits | None = None,
        throttle: bool = True,
    ) -> None:
        if not token.strip():
            raise ValueError("the bridge needs a token that is not blank (the secret clients must send)")
        problem = bind_problem(host, token)
        if problem is not None:
            raise ValueError(f"bridge: {problem}; give a stronger --token: {TOKEN_FIX}")
        self.wrong_tokens = WrongTokens(log=log, what="bridge") if throttle else None
        self.driver = driver
        self.token = token
        self.limits = limits or Limits()
        self.travel = driver.travel()
        self._lock = threading.RLock()  # one driver call at a time (client thread, watchdog thread)
        self._target = (0.0, 0.0, 0.0)  # base velocity the client asked for (clipped)
        self._applied = (0.0, 0.0, 0.0)  # base velocity the driver was last given (ramped)
        self._last_command = time.monotonic()
        self._armed = False  # something may be moving: the watchdog watches
        self._closing = threading.Event()
        self._slot = threading.Lock()  # guards `_client` and `_greeting`
        self._client: Any = None  # the peer being served, None when the robot is free
        self._greeting: dict[str, int] = {}  # connections in their hello, by the peer's address
        self._handoff = queue.Queue()  # type: queue.Queue[tuple[socket.socket, Any, dict[str, Any]]]
        # (monotonic time, why) of the latest safety stops: a flood of refused requests must not grow it
        self.stops = collections.deque(maxlen=1000)  # type: collections.deque[tuple[float, str]]
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._sock.bind((host, port))
        self._sock.listen(MAX_GREETING)  # a burst of connections is accepted, then sorted by the acceptor
        self._sock.settimeout(0.2)  # accept wakes up to notice close()
        self.address = self._sock.getsockname()[:2]
        self._watchdog = threading.Thread(target=self._watch, name="bridge-watchdog", daemon=True)
        self._watchdog.start()

    # --- safety -----------------------------------------------------------------------------------
    def _apply(self, velocity: tuple[float, float, float]) -> None:
        self._applied = velocity
        self.driver.drive(*velocity)

    def _ramp(self, dt: float) -> None:
        """Move the applied base velocity toward the target by at most the acceleration limits over dt."""
        lim = self.limits
        steps = (lim.max_accel * dt, lim.max_accel * dt, lim.max_turn_accel * dt)
        new = tuple(
            self._applied[i] + max(-steps[i], min(steps[i], self._target[i] - self._applied[i]))
            for i in range(3)
        )
        if new != self._applied:
            self._apply((new[0], new[1], new[2]))

    def safety_stop(self, why: str) -> None:
        """Zero the base at once (no ramp: stopping is what safety wants) and hold the arm."""
        with self._lock:
            self._target = (0.0, 0.0, 0.0)
            self._applied = (0.0, 0.0, 0.0)
            self._armed = False
            try:
                self.driver.stop()
            except Exception:  # the robot must still be told to stop by the next path; log it
                log.exception("driver.stop() failed (%s)", why)
            self.stops.append((time.monotonic(), why))
        log.warning("bridge: robot stopped: %s", why)

    def _watch(self) -> None:
        while not self._closing.wait(_RAMP_TICK):
            why = None
            with self._lock:
                if not self._armed:
                    continue
                if time.monotonic() - self._last_command > self.limits.watchdog_s:
                    why = f"no accepted command for {self.limits.watchdog_s:.2f} s (watchdog)"
                elif self.driver.realtime and self._applied != self._target:
                    try:
                        self._ramp(_RAMP_TICK)
                    except Exception:  # the watchdog must outlive a driver's failure, and stop the robot
                        log.exception("bridge: driving the base failed")
                        why = "the driver failed to drive the base"
            if why is not None:
                self.safety_stop(why)

    # --- serving ----------------------------------------------------------------------------------
    def serve_forever(self) -> None:
        """Serve clients one after the other until `close()`, in this thread (the driver's: a simulator's
        GL context belongs to the thread that made it).

        An accepting thread takes each connection's hello, with `HELLO_TIMEOUT_S` to send it, in a thread
        of its own; a client whose version and token are right is handed here when the robot is free, and
        told "robot busy" at once when another client drives it. An idle connection holds nothing."""
        acceptor = threading.Thread(target=self._accept, name="bridge-accept", daemon=True)
        acceptor.start()
        try:
            while not self._closing.is_set():
                try:
                    conn, peer, header = self._handoff.get(timeout=0.2)
                except queue.Empty:
                    continue
                try:
                    self.serve_client(conn, peer, header)
                except Exception:  # a bug met by one client must not end the robot's server
                    log.exception("bridge: serving %s failed", peer)
                    self.safety_stop(f"serving {peer} failed")
                finally:
                    conn.close()
                    self._free(peer)
        finally:
            self._closing.set()
            acceptor.join(timeout=1.0)
            while not self._handoff.empty():
                self._handoff.get_nowait()[0].close()

    def _accept(self) -> None:
        while not self._closing.is_set():
            try:
                conn, peer = self._sock.accept()
            except socket.timeout:  # noqa: UP041 (on Python 3.8 not a TimeoutError: it would end accepting)
                continue
            except OSError:
                break  # closed
            with self._slot:
                address = str(peer[0])
                crowded = (
                    sum(self._greeting.values()) >= MAX_GREETING
                    or self._greeting.get(address, 0) >= MAX_GREETING_PER_ADDRESS
                )
                if not crowded:
                    self._greeting[address] = self._greeting.get(address, 0) + 1
            if crowded:
                log.warning("bridge: refused %s: too many connections in their hello", peer)
                conn.close()
                continue
            threading.Thread(target=self._greet, args=(conn, peer), name="bridge-hello", daemon=True).start()

    def _greet(self, conn: socket.socket, peer: Any) -> None:
        """Read and check one connection's hello; hand it to the serving thread, or refuse it."""
        handed = False
        # the deadline holds for the whole hello: a client that trickles a byte a second is cut too
        cutoff = threading.Timer(HELLO_TIMEOUT_S, _shut, (conn,))
        cutoff.daemon = True
        try:
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            conn.settimeout(HELLO_TIMEOUT_S)
            cutoff.start()
            header, _ = recv_message(conn, MAX_REQUEST_HEADER, 0)
            cutoff.cancel()
            self._check_hello(header, peer)
            with self._slot:
                busy = self._client
                if busy is None:
                    self._client = peer
            if busy is not None:
                log.warning("bridge: refused %s: robot busy with %s", peer, busy)
                raise Refused(
                    "busy",
                    f"robot busy: another client ({busy[0] if isinstance(busy, tuple) else busy}) is "
                    "connected, and the robot serves one client at a time",
                    "wait until that client has finished, then connect again",
                )
            conn.settimeout(None)
            self._handoff.put((conn, peer, header))
            handed = True
        except Refused as exc:
            _answer(conn, exc)
        except MessageError as exc:
            _answer(conn, Refused("hello", f"the hello could not be read: {exc}", _HELLO_FIX))
        except ProtocolError as exc:
            log.info("bridge: connection %s dropped before its hello (%s)", peer, exc)
            if not isinstance(exc, ConnectionClosed):
                _answer(conn, Refused("hello", f"the hello could not be read: {exc}", _HELLO_FIX), last=True)
        except OSError as exc:  # a timeout is an OSError: no hello within the deadline
            log.info("bridge: connection %s dropped before its hello (%s)", peer, exc)
        except Exception:  # nothing a stranger sends may end this thread with a traceback
            log.exception("bridge: the hello of %s failed", peer)
        finally:
            cutoff.cancel()
            with self._slot:
                address = str(peer[0])
                self._greeting[address] -= 1
                if not self._greeting[address]:
                    del self._greeting[address]
            if not handed:
                conn.close()

    def _free(self, peer: Any) -> None:
        """Free the robot for the next client, unless the next one already holds it."""
        with self._slot:
            if self._client == peer:
                self._client = None

    def serve_client(self, conn: socket.socket, peer: Any, hello: dict[str, Any]) -> None:
        """Serve one client whose `hello` was checked: answer it, then its requests until it leaves.

        Only an accepted request feeds the watchdog; anything refused (a request that cannot be read, a
        bad value, an unknown op, a driver's failure) stops the robot before the refusal is sent."""
        authenticated = False
        try:
            with self._lock:
                reply = self._hello_reply()
            reply["ok"] = True
            send_message(conn, reply)
            authenticated = True
            _keep_alive(conn)
            log.info("bridge: client %s connected", peer)
            while not self._closing.is_set():
                try:
                    header, _ = recv_message(conn, MAX_REQUEST_HEADER, 0, within_s=MESSAGE_TIMEOUT_S)
                except MessageError as exc:
                    unread = Refused("message", f"the request could not be read: {exc}", _READ_FIX)
                    self._refuse(conn, unread)
                    continue
                received = time.monotonic()
                op = header.get("op")
                if op == "bye":
                    # stopped and free before the reply: a client that reconnects at once is served
                    self.safety_stop(f"client {peer} said goodbye")
                    authenticated = False
                    self._free(peer)
                    send_message(conn, {"ok": True})
                    break
                try:
                    body, data = self._handle(op if isinstance(op, str) else shown(op), header, received)
                except Refused as exc:
                    self._refuse(conn, exc)
                    continue
                except Exception as exc:  # a driver failure is the client's answer, not the server's death
                    log.exception("bridge: %s failed", shown(op))
                    failure = f"{shown(op)} failed on the robot: {str(exc)[:200]}"
                    self._refuse(conn, Refused("driver", failure, "see the robot's log"))
                    continue
                with self._lock:
                    self._last_command = max(self._last_command, received)
                body["ok"] = True
                send_message(conn, body, data)
        except ProtocolError as exc:
            log.info("bridge: client %s gone (%s)", peer, exc)
            if not isinstance(exc, ConnectionClosed):  # stopped and free first; then it may still read why
                self.safety_stop(f"client {peer} sent what cannot be read ({exc})")
                authenticated = False
                self._free(peer)
                _answer(conn, Refused("message", str(exc), _READ_FIX), last=True)
        except OSError as exc:
            log.info("bridge: client %s gone (%s)", peer, exc)
        finally:
            if authenticated:  # a refused client never moved anything
                self.safety_stop(f"client {peer} disconnected")

    def _refuse(self, conn: socket.socket, refusal: Refused) -> None:
        """Stop the robot (it stops on anything it refuses), then tell the client why."""
        self.safety_stop(f"refused a request ({refusal.code}: {refusal.message[:80]})")
        send_message(conn, {"ok": False, "code": refusal.code, "error": refusal.message, "fix": refusal.fix})

    def _check_hello(self, header: dict[str, Any], peer: Any) -> None:
        if header.get("op") != "hello":
            raise Refused("hello", "the first message must be hello", _HELLO_FIX)
        version = header.get("version")
        if type(version) is not int or version != PROTOCOL_VERSION:
            log.warning("bridge: refused %s: protocol version %r", peer, version)
            raise Refused(
                "version",
                f"protocol version mismatch: the client speaks version {shown(version)}, "
                f"this robot speaks version {PROTOCOL_VERSION}",
                "install the same attribot release on the robot and the planner's computer",
            )
        address = str(peer[0]) if isinstance(peer, tuple) else str(peer)
        throttle = self.wrong_tokens
        if throttle is not None:
            left = throttle.blocked(address)
            if left > 0:
                time.sleep(throttle.BLOCKED_WAIT_S)  # this hello's thread waits; the robot serves on
                raise Refused(
                    "blocked",
                    f"the robot refuses {address} for {left:.0f} s more: too many wrong tokens",
                    "set ATTRIBOT_BRIDGE_TOKEN to the robot's --token, then wait and connect again",
                )
        token = header.get("token")
        if not isinstance(token, str) or not hmac.compare_digest(
            token.encode("utf-8", "surrogatepass"), self.token.encode("utf-8", "surrogatepass")
        ):
            if throttle is None:
                log.warning("bridge: refused %s: wrong token", peer)
            else:
                time.sleep(throttle.wrong(address))  # this hello's thread waits; others are served
            raise Refused(
                "auth",
                "the robot refused the bridge token (wrong shared secret)",
                "set ATTRIBOT_BRIDGE_TOKEN to the --token the robot's `attribot bridge serve` was given",
            )
        if throttle is not None:
            throttle.right(address)

    def _hello_reply(self) -> dict[str, Any]:
        caps = list(self.driver.capabilities())
        reply = {
            "version": PROTOCOL_VERSION,
            "robot": self.driver.name,
            "capabilities": caps,
            "limits": self.limits.as_dict(),
            "travel": {name: [low, high] for name, (low, high) in self.travel.items()},
        }
        if "camera" in caps:
            reply["camera"] = dict(self.driver.camera())
        body = self.driver.body()
        if body is not None:
            reply["body"] = dict(body)
        sensors = [str(s) for s in self.driver.sensors()]
        if sensors:  # optional: a robot that states none keeps the hello of earlier releases
            reply["sensors"] = sensors
        return reply

    def _handle(self, op: str, h: dict[str, Any], received: float) -> tuple[dict[str, Any], bytes]:
        """Do one request received at `received` (monotonic); `Refused` when it cannot be done. A motion
        command feeds the watchdog as it arms it (a tick in between must not find it armed and late)."""
        with self._lock:
            request = REQUESTS.get(op)
            if request is not None:
                return request(self, op, h, received)
        raise Refused("op", f"unknown bridge request {shown(op)}", "see docs/bridge-protocol.md")

    def _step(self, seconds: float) -> None:
        d = self.driver
        if d.realtime:
            # the ramp runs in the watchdog thread; waiting must not hold the lock
            self._lock.release()
            try:
                d.step(seconds)
            finally:
                self._lock.acquire()
            return
        left = seconds
        while left > 1e-12:
            if self._applied == self._target:
                d.step(left)  # nothing to ramp: one call, exactly as the direct world
                return
            dt = min(_RAMP_TICK, left)
            self._ramp(dt)
            d.step(dt)
            left -= dt

    def close(self) -> None:
        self._closing.set()
        try:
            self._sock.close()
        except OSError:
            pass
        self._watchdog.join(timeout=1.0)


def serve_in_thread(
    make_driver: Callable[[], Driver],
    token: str,
    host: str = "127.0.0.1",
    port: int = 0,
    limits: Limits | None = None,
    timeout_s: float = 120.0,
    throttle: bool = True,
) -> tuple[RobotServer, Driver, threading.Thread]:
    """Start a server in a daemon thread that also builds and closes its driver: a driver's resources (a
    simulator's GL context) belong to the thread that made them. `server.close()` stops it; join the
    thread to wait for the driver to be closed."""
    ready = queue.Queue()  # type: queue.Queue[Any]

    def run() -> None:
        try:
            driver = make_driver()
            server = RobotServer(driver, token, host=host, port=port, limits=limits, throttle=throttle)
        except BaseException as exc:  # noqa: BLE001 (handed to the caller, who raises it)
            ready.put(exc)
            return
        ready.put((server, driver))
        try:
            server.serve_forever()
        finally:
            driver.close()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    got = ready.get(timeout=timeout_s)
    if isinstance(got, BaseException):
        raise got
    server, driver = got
    return server, driver, thread
