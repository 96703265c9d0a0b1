"""The editor's state report (`--state PATH`), read by the scripts beside this one, and the way
they start the editor to read it."""
import os
import re
import subprocess
import tempfile


def read_state(path):
    """The report's frame, samples, settled, at_rest, last_busy, denoising, denoise_pass ((pass,
    passes) or None) and traced (pixel samples the latest frame traced), or None while it is
    being written (or not yet there)."""
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
    for name in ("settled", "at_rest", "denoising"):
        m = re.search(r"\b%s: (true|false)" % name, text)
        fields[name] = bool(m and m.group(1) == "true")
    busy = re.search(r"last_busy: \[([^\]]*)\]", text)
    fields["last_busy"] = " ".join(busy.group(1).split()) if busy else ""
    m = re.search(r"\bdenoise_pass: Some\(\(\s*(\d+),\s*(\d+),?\s*\)\)", text)
    fields["denoise_pass"] = (int(m.group(1)), int(m.group(2))) if m else None
    m = re.search(r"\btrace: Some\(\(\s*(\d+),", text)
    fields["traced"] = int(m.group(1)) if m else 0
    return fields


def start_editor(binary, prefix, editor_args, size=(1280, 800), stdout=None):
    """Starts the editor with a configuration and cache of its own (a fresh temporary folder),
    `--state` and a window of `size`: (the process, the report's path, the folder). Its log
    (stderr, and stdout unless `stdout` is given) goes to editor.log in the folder."""
    tmp = tempfile.mkdtemp(prefix=prefix)
    state = os.path.join(tmp, "state.ron")
    env = dict(os.environ, TREELIGHT_CONFIG_DIR=os.path.join(tmp, "config"),
               TREELIGHT_CACHE_DIR=os.path.join(tmp, "cache"))
    args = [binary, "--width", str(size[0]), "--height", str(size[1]), "--state", state]
    log = open(os.path.join(tmp, "editor.log"), "w")
    editor = subprocess.Popen(args + list(editor_args), env=env,
                              stdout=log if stdout is None else stdout, stderr=log)
    return editor, state, tmp
