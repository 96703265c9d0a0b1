"""The editor's state report (`--state PATH`), read by the scripts beside this one."""
import re


def read_state(path):
    """The report's frame, samples, settled, at_rest and last_busy, or None while it is being
    written (or not yet there)."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError:
        return None
    fields = {}
    for name in ("frame", "samples"):
        m = re.search(r"\b%s: (\d+)" % name, text)
        if not m:
            return None  # written while read: the next read has it
        fields[name] = int(m.group(1))
    for name in ("settled", "at_rest"):
        m = re.search(r"\b%s: (true|false)" % name, text)
        fields[name] = bool(m and m.group(1) == "true")
    busy = re.search(r"last_busy: \[([^\]]*)\]", text)
    fields["last_busy"] = " ".join(busy.group(1).split()) if busy else ""
    return fields
