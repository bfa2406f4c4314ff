#!/usr/bin/env python3
"""Runs every example of README.md, docs/*.md and docs/techniques/*.md as written, from the repository root.

What runs (docs/README.md, "Examples in the docs", says the same for writers):

- ```sh blocks: each command (a line, with its `\\` continuations) runs under bash from a working
  directory that looks like the repository root: every top-level entry of the checkout is linked
  into a temporary folder (build/release -> the build tree given by --build-dir), beside a link
  `../shared` to the shared data, so `build/release/penumbra`, `scenes/…` and `../shared/data/…`
  resolve as written while the files an example writes (`-o head.png`, `--stats`, `--buffers .`)
  land in the temporary folder and are removed afterwards. Commands of one run share that folder,
  so a later line reads what an earlier one wrote (`compare head.png ref.png`).
  `penumbra view …` starts the server, waits for the URL it prints first, then stops it (Ctrl-C).
- ```python blocks run in order, each page's blocks in one interpreter (as in a notebook: a later
  block uses what an earlier one made), with the interpreter that runs this script (CMake's
  Python3_EXECUTABLE, Debian's /usr/bin/python3) and PYTHONPATH=build/release/python.
- ```json blocks are parsed; one preceded by `<!-- file: PATH -->` must equal that shipped file.
- ```text and unlabelled blocks are output or listings and are not run, but one holding a line that
  looks like a command (`$ …`, `build/release/penumbra …`, `mpirun …`, `scripts/…`) fails: label it sh.
- A block in any other language (```cpp) must be marked illustrative.

Marking an example illustrative (skipped, with its reason printed):
- a whole block: `<!-- illustrative: REASON -->` on the line before its opening fence;
- one command of a sh block: a trailing comment `# illustrative: REASON`.

--quick (what ctest runs; PENUMBRA_DOCS_QUICK=1 does the same) runs long examples small: each
`penumbra render` without --width/--height gets `--width 64 --height 64` (shadow maps and data keep
their sizes) and averages at most 4 samples (`--accumulate N`), each `penumbra bench` gets `--quick`.
Without it every example runs exactly as written.

Skipped with a reason: examples naming ../shared/data (or a scene that does) where the shared data
are missing, mpirun lines without Open MPI, Python blocks importing a module that is not installed.
Under the sanitizer preset (PENUMBRA_TEST_SCALE=sanitize) the whole test is skipped (exit 77).
As root, OMPI_ALLOW_RUN_AS_ROOT=1 and OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 are set (Open MPI refuses
root without them; README and docs/distributed.md say so).

A failure names FILE:LINE of the example, the command and the end of its stderr; the exit status is 1.
"""
import argparse
import json
import os
import re
import select
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SKIP = 77
TIMEOUT_S = 240  # one example

RUN_LANGS = {"sh", "bash", "shell"}
OUTPUT_LANGS = {"", "text", "console-output", "output"}
COMMAND_LIKE = re.compile(r"^\s*(\$ |(\./)?build/release/penumbra\b|penumbra (render|view|info|bench|demo|compare|montage)\b|"
                          r"mpirun\b|(\./)?scripts/|PYTHONPATH=|(/usr/bin/)?python3 |cmake )")
BLOCK_MARK = re.compile(r"^\s*<!--\s*illustrative:\s*(.*?)\s*-->\s*$")
FILE_MARK = re.compile(r"^\s*<!--\s*file:\s*(\S+)\s*-->\s*$")


class Example:
    def __init__(self, path, line, kind, text, reason=None, target=None):
        self.path, self.line, self.kind, self.text = path, line, kind, text
        self.reason = reason    # illustrative: why it is not run
        self.target = target    # json: the shipped file it must equal

    @property
    def where(self):
        return f"{self.path}:{self.line}"


def doc_files():
    files = ["README.md"]
    for folder in ("docs", os.path.join("docs", "techniques")):
        for name in sorted(os.listdir(os.path.join(ROOT, folder))):
            if name.endswith(".md"):
                files.append(os.path.join(folder, name))
    return files


def split_comment(line):
    """(code, comment) of one shell line: a # outside quotes that starts a word begins the comment."""
    quote = None
    i = 0
    while i < len(line):
        c = line[i]
        if quote:
            if c == "\\" and quote == '"':
                i += 1
            elif c == quote:
                quote = None
        elif c in "'\"":
            quote = c
        elif c == "\\":
            i += 1
        elif c == "#" and (i == 0 or line[i - 1] in " \t"):
            return line[:i].rstrip(), line[i + 1:].strip()
        i += 1
    return line.rstrip(), ""


def parse(path):
    """The examples of one Markdown file."""
    with open(os.path.join(ROOT, path), encoding="utf-8") as f:
        lines = f.read().split("\n")
    examples = []
    i = 0
    prev = ""  # the last non-blank line before a fence
    while i < len(lines):
        m = re.match(r"^(\s*)(```+|~~~+)\s*([\w+-]*)", lines[i])
        if not m:
            if lines[i].strip():
                prev = lines[i]
            i += 1
            continue
        indent, fence, lang = len(m.group(1)), m.group(2), m.group(3).lower()
        start = i + 1  # 1-based line of the fence is i + 1; the block's first line is i + 2
        body = []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence[:3]):
            body.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i])
            i += 1
        i += 1  # the closing fence
        mark = BLOCK_MARK.match(prev)
        reason = mark.group(1) if mark else None
        file_mark = FILE_MARK.match(prev)
        prev = ""
        first = start + 1  # line number of body[0]
        if lang in RUN_LANGS:
            k = 0
            while k < len(body):
                line_no = first + k
                text = body[k]
                while text.endswith("\\") and k + 1 < len(body):
                    k += 1
                    text = text + "\n" + body[k]  # bash reads the backslash-newline as written
                k += 1
                code, comment = split_comment(text.split("\n")[-1])
                code = "\n".join(text.split("\n")[:-1] + [code]).strip()
                if not code:
                    continue
                why = reason
                im = re.search(r"illustrative:\s*(.*)", comment)
                if im:
                    why = im.group(1).strip()
                examples.append(Example(path, line_no, "sh", code, why))
        elif lang == "python":
            examples.append(Example(path, first, "python", "\n".join(body), reason))
        elif lang == "json":
            examples.append(Example(path, first, "json", "\n".join(body), reason,
                                    file_mark.group(1) if file_mark else None))
        elif lang in OUTPUT_LANGS:
            for k, text in enumerate(body):
                if COMMAND_LIKE.match(text) and not reason:
                    examples.append(Example(path, first + k, "unlabelled", text.strip()))
        else:
            examples.append(Example(path, first, "other:" + lang, "\n".join(body), reason))
    return examples


# ---------------------------------------------------------------------------------------------------
# Running


class Runner:
    def __init__(self, args):
        self.args = args
        self.build_dir = os.path.abspath(args.build_dir or os.path.join(ROOT, "build", "release"))
        self.quick = args.quick or os.environ.get("PENUMBRA_DOCS_QUICK", "") not in ("", "0")
        shared = os.path.join(os.path.dirname(ROOT), "shared")
        self.shared = shared if os.path.isdir(os.path.join(shared, "data")) else None
        self.tmp = tempfile.mkdtemp(prefix="penumbra-docs-")
        self.work = os.path.join(self.tmp, os.path.basename(ROOT))
        os.mkdir(self.work)
        for name in os.listdir(ROOT):
            if name != "build":
                os.symlink(os.path.join(ROOT, name), os.path.join(self.work, name))
        os.makedirs(os.path.join(self.work, "build"))
        os.symlink(self.build_dir, os.path.join(self.work, "build", "release"))
        if self.shared:
            os.symlink(self.shared, os.path.join(self.tmp, "shared"))
        self.env = dict(os.environ)
        self.env["PYTHONPATH"] = os.pathsep.join(p for p in ["build/release/python", os.environ.get("PYTHONPATH", "")] if p)
        if os.geteuid() == 0:
            self.env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
            self.env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        self.have_mpirun = shutil.which("mpirun") is not None
        self.not_made = set()  # outputs of skipped commands

    def close(self):
        if self.args.keep:
            print(f"outputs kept in {self.work}")
        else:
            shutil.rmtree(self.tmp, ignore_errors=True)

    # -- what an example needs -----------------------------------------------------------------------
    def needs_shared(self, text):
        if "shared/data" in text:
            return True
        for scene in re.findall(r"scenes/[\w.-]+\.json", text):
            p = os.path.join(ROOT, scene)
            if os.path.isfile(p):
                with open(p, encoding="utf-8") as f:
                    if "shared/data" in f.read():
                        return True
        return False

    def outputs(self, ex):
        """The files a skipped command would have written, which later commands may read."""
        words = shlex.split(ex.text.replace("\\\n", " "), comments=True)
        return {words[k + 1] for k, w in enumerate(words[:-1]) if w in ("-o", "--output", "--stats", "--diff", "--write-scene")}

    def skip_reason(self, ex):
        if ex.reason:
            return "illustrative: " + ex.reason
        if ex.kind == "sh":
            words = set(shlex.split(ex.text.replace("\\\n", " "), comments=True))
            missing = sorted((words - self.outputs(ex)) & self.not_made)
            if missing:
                return f"reads {', '.join(missing)}, which a skipped example makes"
        if not self.shared and self.needs_shared(ex.text):
            return "needs ../shared/data, which is missing here"
        if ex.kind == "sh" and re.match(r"\s*mpirun\b", ex.text) and not self.have_mpirun:
            return "mpirun not installed (scripts/install-deps.sh installs Open MPI)"
        return None

    # -- sh ------------------------------------------------------------------------------------------
    def quick_command(self, cmd):
        if not self.quick or re.search(r"[|;&<>]", cmd):
            return cmd
        words = shlex.split(cmd.replace("\\\n", " "))
        for k, w in enumerate(words):
            if w.endswith("penumbra") and k + 1 < len(words):
                sub = words[k + 1]
                if sub == "render":
                    cmd = re.sub(r"(--accumulate[ =])(\d+)", lambda m: m.group(1) + str(min(int(m.group(2)), 4)), cmd)
                    if "--width" not in words and "--height" not in words:
                        cmd += " --width 64 --height 64"
                    return cmd
                if sub == "bench" and "--quick" not in words:
                    return cmd + " --quick"
                break
        return cmd

    def run_sh(self, ex):
        cmd = self.quick_command(ex.text)
        words = shlex.split(ex.text.replace("\\\n", " "))
        if len(words) >= 2 and words[0].endswith("penumbra") and words[1] == "view":
            return self.run_server(ex, cmd)
        # its own process group, so that a timeout stops what it started too (mpirun's ranks)
        p = subprocess.Popen(["bash", "-c", cmd], cwd=self.work, env=self.env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            out, err = p.communicate(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            out, err = p.communicate()
            return False, f"timed out after {TIMEOUT_S} s\n{err[-3000:]}", cmd
        if p.returncode != 0:
            return False, f"exit status {p.returncode}\n{err[-3000:] or out[-3000:]}", cmd
        return True, "", cmd

    def run_server(self, ex, cmd):
        """penumbra view: it must print its URL as its first line; then Ctrl-C stops it."""
        p = subprocess.Popen(["bash", "-c", "exec " + cmd], cwd=self.work, env=self.env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL)
        line = ""
        try:
            ready, _, _ = select.select([p.stdout], [], [], 120)  # the data loaded, the port bound
            if ready:
                line = p.stdout.readline()
        finally:
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
            try:
                _, err = p.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                _, err = p.communicate()
        if not line.startswith("http://"):
            return False, f"no URL on its first line (exit status {p.returncode})\n{line}{err[-3000:]}", cmd + "  (server)"
        return True, "", cmd + "  (server: printed " + line.strip().split("?")[0] + ", stopped)"

    # -- python --------------------------------------------------------------------------------------
    DRIVER = r"""
import json, sys, time, traceback
blocks = json.load(sys.stdin)
ns = {"__name__": "__main__"}
for path, line, src in blocks:
    t = time.perf_counter()
    try:
        exec(compile("\n" * (line - 1) + src, path, "exec"), ns)
    except BaseException:
        print("@@FAIL %d" % line, flush=True)
        traceback.print_exc()
        sys.stderr.flush()
        sys.exit(1)
    print("@@OK %d %.2f" % (line, time.perf_counter() - t), flush=True)
"""

    def run_python(self, page_examples):
        """Runs one page's Python blocks in one interpreter; returns [(example, ok, message, seconds)]."""
        payload = json.dumps([[ex.path, ex.line, ex.text] for ex in page_examples])
        try:
            p = subprocess.run([sys.executable, "-c", self.DRIVER], cwd=self.work, env=self.env, input=payload,
                               capture_output=True, text=True, timeout=TIMEOUT_S * len(page_examples))
            out, err, timed_out = p.stdout, p.stderr, False
        except subprocess.TimeoutExpired as e:
            out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
            err = e.stderr.decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
            timed_out = True
        done = {}
        failed = None
        for line in out.splitlines():
            if line.startswith("@@OK "):
                _, n, s = line.split()
                done[int(n)] = float(s)
            elif line.startswith("@@FAIL "):
                failed = int(line.split()[1])
        results = []
        blamed = False
        for ex in page_examples:
            if ex.line in done:
                results.append((ex, True, "", done[ex.line]))
            elif not blamed and (failed is None or failed == ex.line):
                blamed = True
                why = f"timed out after {TIMEOUT_S * len(page_examples)} s" if timed_out else "raised"
                at = re.findall(r'File "' + re.escape(ex.path) + r'", line (\d+)', err)
                if at:
                    why += f" at {ex.path}:{at[-1]}"
                results.append((ex, False, f"{why}\n{err[-3000:]}", 0.0))
            else:
                results.append((ex, None, "not run: an earlier block of this page failed", 0.0))
        return results


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="long examples small (PENUMBRA_DOCS_QUICK=1 does the same)")
    ap.add_argument("--build-dir", help="the build tree that build/release stands for (default: build/release)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary working folder and print it")
    ap.add_argument("--list", action="store_true", help="list the examples and what would happen, run nothing")
    ap.add_argument("only", nargs="*", help="FILE or FILE:LINE: run only these examples")
    args = ap.parse_args()

    if os.environ.get("PENUMBRA_TEST_SCALE") == "sanitize":
        print("docs examples: skipped under the sanitizer preset (they run the release build's tools)")
        return SKIP

    examples = []
    for path in doc_files():
        examples += parse(path)
    if args.only:
        examples = [ex for ex in examples if any(ex.path == o or ex.where == o for o in args.only)]
        if not examples:
            print(f"no example at {' '.join(args.only)}")
            return 1

    runner = Runner(args)
    failures = []
    counts = {"passed": 0, "skipped": 0, "failed": 0}
    t_all = time.perf_counter()

    def report(ex, ok, msg, seconds, shown=None):
        if shown is None:
            shown = ex.text.replace("\\\n", " ").replace("\n", " ") if ex.kind in ("sh", "unlabelled") else f"{ex.kind} block"
        shown = re.sub(r"\s+", " ", shown)
        if ok is True:
            counts["passed"] += 1
            print(f"ok      {ex.where:<32} {seconds:6.1f} s  {shown}", flush=True)
        elif ok is None:
            counts["skipped"] += 1
            print(f"skipped {ex.where:<32} {msg}", flush=True)
        else:
            counts["failed"] += 1
            failures.append((ex, msg, shown))
            print(f"FAILED  {ex.where:<32} {seconds:6.1f} s  {shown}", flush=True)

    try:
        pending_python = []

        def flush_python():
            if not pending_python:
                return
            runnable = []
            cascade = None  # a block skipped for what this machine lacks: the page's later blocks may need it
            for ex in pending_python:
                why = runner.skip_reason(ex)
                if why is None and cascade:
                    why = f"an earlier block of this page ({cascade}) is skipped"
                for mod in ([] if why else re.findall(r"^\s*import (\w+)", ex.text, re.M)):
                    if mod not in ("penumbra", "numpy") and subprocess.run(
                            [sys.executable, "-c", f"import {mod}"], capture_output=True).returncode != 0:
                        why = f"Python module {mod} not installed"
                if why:
                    report(ex, None, why, 0)
                    if not ex.reason:
                        cascade = cascade or ex.where
                elif args.list:
                    report(ex, None, "would run (python)", 0)
                else:
                    runnable.append(ex)
            if runnable:
                for ex, ok, msg, s in runner.run_python(runnable):
                    report(ex, ok, msg, s, f"python block ({len(ex.text.splitlines())} lines)")
            pending_python.clear()

        current = None
        for ex in examples:
            if ex.path != current:
                flush_python()
                current = ex.path
            if ex.kind == "python":
                pending_python.append(ex)
                continue
            if ex.kind == "unlabelled":
                report(ex, False, "a command in a block that is not ```sh: label the block sh (it then runs), or mark "
                       "it <!-- illustrative: REASON -->", 0)
                continue
            why = runner.skip_reason(ex)
            if why:
                report(ex, None, why, 0)
                if ex.kind == "sh":
                    runner.not_made |= runner.outputs(ex)
                continue
            if ex.kind.startswith("other:"):
                report(ex, False, f"a ```{ex.kind[6:]} block is neither run nor marked <!-- illustrative: REASON -->", 0)
                continue
            if ex.kind == "json":
                try:
                    value = json.loads(ex.text)
                    if ex.target:
                        with open(os.path.join(ROOT, ex.target), encoding="utf-8") as f:
                            if json.load(f) != value:
                                raise ValueError(f"differs from {ex.target}")
                except (ValueError, OSError) as e:
                    report(ex, False, f"not valid JSON or not the shipped file: {e}", 0, "json block")
                    continue
                report(ex, True, "", 0, "json block" + (f" = {ex.target}" if ex.target else " (parsed)"))
                continue
            if args.list:
                report(ex, None, "would run: " + runner.quick_command(ex.text), 0)
                continue
            runner.not_made -= runner.outputs(ex)
            t = time.perf_counter()
            ok, msg, shown = runner.run_sh(ex)
            report(ex, ok, msg, time.perf_counter() - t, shown)
        flush_python()
    finally:
        runner.close()

    total = time.perf_counter() - t_all
    print(f"\n{counts['passed']} passed, {counts['skipped']} skipped, {counts['failed']} failed in {total:.1f} s"
          f"{' (--quick)' if runner.quick else ''}")
    for ex, msg, shown in failures:
        print(f"\n{ex.where}: this example failed:\n    {shown}\n" + "\n".join("    " + l for l in msg.rstrip().splitlines()))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
