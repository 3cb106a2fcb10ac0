"""The ODrive's reply lines, judged on the bytes that came (``protocols.md`` §4.2–4.4).

A reply line is printable ASCII ending in CR LF, ``text*<decimal XOR of text>`` when the
request carried a checksum. On USB nothing but replies arrives; on the board's UART pins
(GPIO1/2) line noise can put any bytes between two lines, flip, drop or add a byte. An
8-bit XOR cannot tell everything apart — a run of characters whose XOR is zero (``11``,
``1221``) can sit in front of a reply and leave its checksum as it was — so a line is not
believed because its checksum passes, but because **it is the only reply the bytes can
hold**: under the fault model

* any bytes before the reply (noise on an idle line), and
* at most one fault within the reply and its checksum (a byte flipped, dropped or
  inserted, a flipped byte that became a control character cutting the line in two),

every reply text consistent with what came is enumerated, each held to the form the
request's reply has (:data:`FORMS`: ``%f`` cut to 9 characters for ``r``, ``%f %f`` for
``f``), and a line is taken only when exactly one candidate remains and it is a literal
part of the bytes (nothing is repaired). Anything else is refused and counted: a refused
reply costs a retry, a believed wrong number would cost a robot.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from kit.drivers.checksums import odrive_checksum
from kit.drivers.errors import ChecksumError, DeviceError, ProtocolError

__all__ = ["DEVICE", "ERROR_REPLIES", "FORMS", "ReplyLines", "ReplySplitter", "judge_line",
           "line_candidates", "parse_reply", "raise_if_error"]

DEVICE = "ODrive"
ERROR_REPLIES = ("invalid command format", "invalid motor", "invalid property",
                 "not implemented", "unknown command")
CR_FLIPPED = ("-", "M")
"""the printable bytes one flipped bit makes of CR (0x0D ^ 0x20, 0x0D ^ 0x40)."""

_NUMBER = r"-?(?:0|[1-9][0-9]*)"
_FULL_F = re.compile(_NUMBER + r"\.[0-9]{6}|-?inf|nan")
_CUT_F = re.compile(_NUMBER + r"(?:\.[0-9]*)?")
_INT = re.compile(_NUMBER)
_FEEDBACK = re.compile(_NUMBER + r"\.[0-9]{6} " + _NUMBER + r"\.[0-9]{6}")
_ERROR = re.compile(r"invalid command format|invalid motor [0-9]+|invalid property|"
                    r"not implemented|unknown command")
_INFO = re.compile(r"(?:Hardware version|Firmware version|Serial number): [ -~]*")
_NUMERIC = frozenset("0123456789.- ")
_PRINTABLE = frozenset(chr(c) for c in range(0x20, 0x7F))


def _number9(text: str) -> bool:
    """An ``r`` reply: ``%f`` or an integer, cut to 9 characters by the firmware."""
    if not 0 < len(text) <= 9:
        return False
    if _FULL_F.fullmatch(text) or _INT.fullmatch(text):
        return True
    return len(text) == 9 and _CUT_F.fullmatch(text) is not None


FORMS: dict[str, Callable[[str], bool]] = {
    "number": _number9,
    "feedback": lambda t: _FEEDBACK.fullmatch(t) is not None,
    "reply": lambda t: _number9(t) or _FEEDBACK.fullmatch(t) is not None,
    "info": lambda t: _INFO.fullmatch(t) is not None,
}
"""what each kind of request's reply looks like: ``number`` (``r``: ``%f`` or an integer,
cut to 9 characters), ``feedback`` (``f``: ``%f %f``), ``reply`` (either), ``info`` (the
lines of ``i``). The firmware's error replies fit every form."""


def _fits(form: str, text: str) -> bool:
    return _ERROR.fullmatch(text) is not None or FORMS[form](text)


def _printable(raw: bytes) -> bool:
    return all(0x20 <= b <= 0x7E for b in raw)


def parse_reply(line: str | bytes, checksum: bool = False) -> str:
    """A reply line (without CR LF) → its text, the checksum checked when expected.

    The line is judged as the bytes that came: the firmware's replies are printable ASCII,
    so any other byte (or character) means line noise, and the checksum is the XOR of those
    bytes (two bytes that would both decode to U+FFFD cannot cancel out).

    Raises :class:`ChecksumError` for a missing or wrong checksum, :class:`ProtocolError`
    for a line that is not printable ASCII, and :class:`DeviceError` for the firmware's
    error replies (``invalid property`` …).

    >>> parse_reply(b"24.087744*32", checksum=True)
    '24.087744'
    """
    if isinstance(line, str):
        try:
            raw = line.encode("ascii")
        except UnicodeEncodeError:
            raise ProtocolError(DEVICE, f"reply is not ASCII: {line[:60]!r}") from None
    else:
        raw = bytes(line)
    if not _printable(raw):
        raise ProtocolError(DEVICE, f"reply holds bytes the firmware never sends: {raw[:60]!r}")
    text = raw.decode("ascii")
    if checksum:
        body, star, given = text.rpartition("*")
        if not star or not given.isdigit():
            raise ChecksumError(DEVICE, f"reply without a checksum: {text[:60]!r}")
        if odrive_checksum(body) != int(given):
            raise ChecksumError(DEVICE, f"checksum {given} does not match "
                                        f"{odrive_checksum(body)} for {body[:60]!r}")
        text = body
    raise_if_error(text)
    return text


def raise_if_error(text: str) -> None:
    """:class:`DeviceError` (``code`` 1–5 in :data:`ERROR_REPLIES`' order) for the firmware's
    error replies."""
    for code, error in enumerate(ERROR_REPLIES, start=1):
        if text.startswith(error):
            raise DeviceError(DEVICE, text, code)


def _checksum_edits(given: str) -> set[int]:
    """The checksums one flipped, dropped or added digit makes of ``given``."""
    digits = "0123456789"
    variants = {given[:i] + given[i + 1:] for i in range(len(given))}
    variants |= {given[:i] + d + given[i:] for i in range(len(given) + 1) for d in digits}
    variants |= {given[:i] + d + given[i + 1:] for i in range(len(given)) for d in digits}
    return {int(v) for v in variants if v.isdigit() and int(v) <= 255} - {int(given)}


def _edits(line: str, body_xor: int, cs: int, form: str,
           alphabet: frozenset[str]) -> set[str]:
    """The replies, fitting ``form`` with checksum ``cs``, of which ``line`` (a body, no
    control characters) is a copy with one byte dropped, added or with one bit flipped."""
    d = body_xor ^ cs
    out: set[str] = set()
    if not d:
        return out
    c = chr(d)
    if c in alphabet:  # ``c`` was dropped
        out |= {t for p in range(len(line) + 1)
                if _fits(form, t := line[:p] + c + line[p:])}
    for p, ch in enumerate(line):
        if ord(ch) == d and _fits(form, t := line[:p] + line[p + 1:]):  # ``ch`` was added
            out.add(t)
        changed = chr(ord(ch) ^ d)
        if d & (d - 1) == 0 and changed in alphabet and \
                _fits(form, t := line[:p] + changed + line[p + 1:]):
            out.add(t)  # ``changed`` arrived as ``ch``, one bit flipped
    return out


def _split_checksum(text: str) -> tuple[str, str] | None:
    body, star, given = text.rpartition("*")
    if not star or not given.isdigit() or len(given) > 3 or int(given) > 255:
        return None
    return body, given


def _xor(text: str) -> int:
    c = 0
    for ch in text:
        c ^= ord(ch)
    return c


def line_candidates(run: bytes, before: bytes = b"", form: str = "reply"
                    ) -> tuple[set[str], set[str]]:
    """The replies a run can hold (see :func:`judge_line`): ``(literal, repaired)``, those
    there as they came and those one fault away."""
    return _candidates(run, before, form)


def judge_line(run: bytes, before: bytes = b"", form: str = "reply") -> tuple[str | None, str]:
    """Judge one run of printable bytes (a line as cut by :class:`ReplySplitter`) carrying a
    checksum: ``(text, "ok")`` for the one reply it can hold, else ``(None, why)`` with
    ``why`` ``"no reply"`` or ``"ambiguous"``. ``before`` is what came since the last line
    end before the run: noise, or the head of the reply cut off by a byte that noise turned
    into a control character.

    The replies the bytes can hold, each fitting ``form`` and its checksum:

    * noise before the reply: every tail of the run (nothing repaired);
    * one fault in the line (``before`` and the run together, from the last line end): the
      line with one byte dropped, added or changed, a checksum digit damaged, or the run's
      own CR flipped into ``-`` or ``M``.

    A run is taken when they all agree and the reply is there as it came.

    >>> judge_line(b"24.087744*32", form="number")
    ('24.087744', 'ok')
    >>> judge_line(b"@#1.500000 0.250000*35", form="feedback")   # noise in front
    ('1.500000 0.250000', 'ok')
    >>> judge_line(b"33115.200000 0.500000*34", form="feedback")  # '33' XORs to zero
    (None, 'ambiguous')
    """
    literal, repaired = _candidates(run, before, form)
    candidates = literal | repaired
    if len(candidates) > 1:
        return None, "ambiguous"
    if not literal or candidates != literal:
        return None, "no reply" if not candidates else "ambiguous"
    return next(iter(literal)), "ok"


def _candidates(run: bytes, before: bytes, form: str) -> tuple[set[str], set[str]]:
    alphabet = _PRINTABLE if form == "info" else _NUMERIC
    text = run.decode("ascii", "replace")
    literal: set[str] = set()  # replies that are in the run as they came
    repaired: set[str] = set()  # replies one fault away
    split = _split_checksum(text)
    if split is not None:  # noise before the reply: any tail of the run
        body, given = split
        cs = int(given)
        start = body.rfind("*") + 1  # a reply's text holds no '*'
        tail = 0
        for k in range(len(body) - 1, start - 1, -1):
            tail ^= ord(body[k])
            if tail == cs and _fits(form, body[k:]):
                literal.add(body[k:])
    line = before + run
    junk = [i for i, b in enumerate(line) if not 0x20 <= b <= 0x7E]
    ends = [text] + ([text[:-1]] if text[-1:] in CR_FLIPPED and len(text) > 1 else [])
    for n, end in enumerate(ends):
        split = _split_checksum(end)
        if split is None:
            continue
        body, given = split
        cs = int(given)
        if n:  # the CR flipped: that is the fault
            if _xor(body) == cs and _fits(form, body) and not junk:
                literal.add(body)
            continue
        if not junk:  # one fault in the body or its checksum
            whole = _xor(body)
            repaired |= _edits(body, whole, cs, form, alphabet)
            repaired |= {body for other in _checksum_edits(given)
                         if whole == other and _fits(form, body)}
        elif len(junk) == 1:  # the one control character is the fault
            head = line[:junk[0]].decode("ascii")
            if "*" in head or not body:  # a line end lost before: not one fault
                continue
            rest = body
            x = _xor(head) ^ _xor(rest)
            if x == cs and _fits(form, head + rest):
                repaired.add(head + rest)  # it was added
            flip = x ^ cs ^ line[junk[0]]
            changed = chr(x ^ cs)
            if flip and flip & (flip - 1) == 0 and changed in alphabet and \
                    _fits(form, t := head + changed + rest):
                repaired.add(t)  # a byte of the reply, one bit flipped, turned into it
    return literal, repaired


class ReplySplitter:
    """Bytes → runs of printable bytes, each with what came before it since the last line
    end (CR LF).

    The firmware ends every reply line with CR LF and sends nothing but printable ASCII in
    between, so a line is a run of printable bytes and anything else ends it: a line end
    damaged by noise splits two replies instead of merging them. A run longer than ``limit``
    bytes (the firmware's 256) is dropped, counted in ``dropped``.

    >>> ReplySplitter().feed(b"1.5*31\\r\\n2.0 0.0\\r*31\\r\\n")
    [(b'1.5*31', b''), (b'2.0 0.0', b''), (b'*31', b'2.0 0.0\\r')]
    """

    def __init__(self, limit: int = 256) -> None:
        self.limit = limit
        self.dropped = 0
        self._line = bytearray()
        self._before = bytearray()  # since the last CR LF, up to the run being read

    def feed(self, data: bytes) -> list[tuple[bytes, bytes]]:
        out: list[tuple[bytes, bytes]] = []
        line, before = self._line, self._before
        for b in data:
            if 0x20 <= b <= 0x7E:
                line.append(b)
                if len(line) > self.limit:
                    self.dropped += len(line)
                    line.clear()
                continue
            if line:
                out.append((bytes(line), bytes(before)))
                before += line
                line.clear()
            before.append(b)
            if before.endswith(b"\r\n"):
                before.clear()
            elif len(before) > 2 * self.limit:
                del before[:-self.limit]
        return out


class ReplyLines:
    """Bytes → the reply texts they certainly hold: :class:`ReplySplitter`'s runs judged by
    :func:`judge_line` (with ``checksum``), or, without checksums, every run that fits
    ``form`` (nothing can be checked then). Refused runs are counted in ``rejected`` (and
    ``ambiguous``, those that could be more than one reply); the firmware's error replies
    raise :class:`DeviceError`.

    >>> ReplyLines(checksum=True).feed(b"24.087744*32\\r\\n1.0*3\\r\\n")
    ['24.087744']
    """

    def __init__(self, checksum: bool = True, limit: int = 256, form: str = "reply") -> None:
        if form not in FORMS:
            raise ValueError(f"form must be one of {sorted(FORMS)}; got {form!r}")
        self.checksum = checksum
        self.form = form
        self.splitter = ReplySplitter(limit)
        self.rejected = 0
        self.ambiguous = 0

    def _candidates(self, run: bytes, before: bytes) -> tuple[frozenset[str], frozenset[str]]:
        if not self.checksum:
            text = run.decode("ascii")
            found = frozenset((text,)) if _fits(self.form, text) else frozenset()
            return found, found
        literal, repaired = _candidates(run, before, self.form)
        return frozenset(literal | repaired), frozenset(literal)

    def feed_sets(self, data: bytes) -> list[tuple[frozenset[str], frozenset[str]]]:
        """Every run that can hold a reply, as ``(candidates, literal)``: the replies it
        can hold, and those of them there as they came. One literal candidate is a certain
        reply (the firmware's errors raised); several are an ambiguous one, which the
        caller may tell apart with another reading (:meth:`feed` refuses them)."""
        out: list[tuple[frozenset[str], frozenset[str]]] = []
        for run, before in self.splitter.feed(data):
            candidates, literal = self._candidates(run, before)
            certain = len(candidates) == 1 and candidates == literal
            if certain:
                raise_if_error(next(iter(candidates)))
            else:
                self.rejected += 1
                if len(candidates) > 1:
                    self.ambiguous += 1
            if certain or (len(candidates) > 1 and literal):
                out.append((candidates, literal))
        return out

    def feed(self, data: bytes) -> list[str]:
        return [next(iter(c)) for c, literal in self.feed_sets(data)
                if len(c) == 1 and c == literal]
