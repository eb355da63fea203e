#!/usr/bin/python3
"""Hostile inputs to hyq-id, hyq-qp-solve and hyq-candump: each gives one
clear message naming the input and a non-zero exit, never a crash, an abort or a hang, and
hyq-id still solves the good lines around a bad one.

usage: hostile_input_test.py CASE TOOL DATA_DIR WORK_DIR
  CASE: id_lines | id_files | qp_files | candump_dev_zero
Prints PASS at the end; any failed check exits 1 with the tool's output.
"""
import os
import subprocess
import sys

failures = []


def run(argv, timeout=60):
    """(exit status, stdout + stderr); a signal shows as -N, a hang as 'timeout'."""
    try:
        p = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout", ""
    return p.returncode, p.stdout.decode(errors="replace")


def check(what, ok, detail=""):
    print("%s: %s" % ("ok  " if ok else "FAIL", what))
    if not ok:
        failures.append(what)
        print(detail)


def expect(what, argv, code, *pieces, timeout=60):
    rc, out = run(argv, timeout)
    check("%s: exit %s (found %s)" % (what, code, rc), rc == code, out)
    for piece in pieces:
        check("%s: says %r" % (what, piece), piece in out, out)
    return out


def write(path, text):
    with open(path, "w") as f:
        f.write(text)
    return path


def deep(n):
    return "[" * n + "]" * n


def id_lines(tool, data, work):
    good = open(os.path.join(data, "id_two_lines.jsonl")).read().splitlines()
    bad_number = good[0].replace('"h":', '"h":1e999,"x":', 1)
    lines = [good[0], bad_number, deep(100000), "[" + "1," * 600000 + "1]", good[1],
             '{"q": "' + "[" * 1000 + '"}']
    src = write(os.path.join(work, "hostile.jsonl"), "\n".join(lines) + "\n")
    out_path = os.path.join(work, "hostile.out.jsonl")
    # before: the 1e999 line aborted hyq-id (uncaught out_of_range) and every later line was lost;
    # the deep line segfaulted
    expect("hyq-id on bad lines among good ones", [tool, src, out_path], 1,
           "hostile.jsonl:2: expected numbers within the range of a double, found:",
           "number overflow parsing '1e999'",
           "hostile.jsonl:3: expected arrays and objects nested at most 64 deep, found more",
           "hostile.jsonl:4: expected a line of at most 1048576 bytes, found a longer one",
           "hostile.jsonl:6: \"q\": expected an array of 19 numbers",
           "2 solved (0 fell back), 4 bad line(s)")
    with open(out_path) as f:
        check("both good lines solved", len(f.read().splitlines()) == 2)


def id_files(tool, data, work):
    src = os.path.join(data, "id_two_lines.jsonl")
    # before: read /dev/zero until bad_alloc (or the OOM killer)
    expect("hyq-id --urdf /dev/zero", [tool, "--urdf", "/dev/zero", src, os.devnull], 2,
           "--urdf /dev/zero: expected a regular file, found a character device", timeout=20)
    expect("hyq-id --urdf DIR", [tool, "--urdf", work, src, os.devnull], 2,
           "expected a regular file, found a directory")
    # before: a directory read as an empty file, exit 0
    expect("hyq-id on a directory", [tool, work, os.devnull], 2,
           work + ": expected a regular file, found a directory")
    expect("hyq-id on /dev/zero", [tool, "/dev/zero", os.devnull], 2,
           "/dev/zero: expected a regular file, found a character device", timeout=20)


def qp_files(tool, data, work):
    def f(name, text):
        return write(os.path.join(work, name), text)

    # before: abort (uncaught out_of_range), SIGSEGV, abort (ios failure), "optimal" with x null
    expect("1e999", [tool, f("big.json", '{"H": [[1e999]], "g": [1]}')], 2,
           "big.json: expected numbers within the range of a double, found:",
           "number overflow parsing '1e999'")
    expect("deep nesting", [tool, f("deep.json", deep(100000))], 2,
           "deep.json: expected arrays and objects nested at most 64 deep, found more")
    expect("deep nesting inside a key", [tool, f("deep2.json", '{"H": ' + deep(65) + '}')], 2,
           "nested at most 64 deep")
    expect("a directory", [tool, work], 2, work + ": expected a regular file, found a directory")
    expect("/dev/zero", [tool, "/dev/zero"], 2,
           "/dev/zero: expected a regular file, found a character device", timeout=20)
    expect("H = diag(1e308)", [tool, f("hbig.json", '{"H": [[1e308, 0], [0, 1e308]], "g": [1, 1]}')],
           2, 'hbig.json: key "H[0][0]": expected a number of magnitude at most 1e150, found number 1e+308')
    expect("g = ±1e308", [tool, f("gbig.json", '{"H": [[1, 0], [0, 1]], "g": [1e308, -1e308]}')],
           2, 'key "g[0]": expected a number of magnitude at most 1e150')
    expect("ub = 1e200", [tool, f("ubbig.json", '{"H": [[1]], "g": [1], "ub": [1e200]}')], 2,
           'key "ub[0]": expected a number of magnitude at most 1e150, or null for an infinite bound')
    # within the limits, but x = -g/H = -1e400 overflows: the solver must not call that optimal
    out = expect("x overflows", [tool, f("xbig.json", '{"H": [[1e-300]], "g": [1e100]}')], 1,
                 '"status": "bad_input"')
    check("x overflows: not optimal", '"optimal"' not in out, out)
    expect("the example still solves", [tool, os.path.join(data, "..", "..", "qp", "data",
                                                            "tool_example.json")], 0,
           '"status": "optimal"')


def candump_dev_zero(tool, data, work):
    # before: read /dev/zero into memory until bad_alloc (or the OOM killer)
    expect("hyq-candump replay:/dev/zero", [tool, "-n", "1", "-t", "5", "-o", os.devnull,
                                            "replay:/dev/zero"], 1,
           "candump log /dev/zero: expected a regular file, found a character device", timeout=20)


def main():
    case, tool, data, work = sys.argv[1:5]
    os.makedirs(work, exist_ok=True)
    {"id_lines": id_lines, "id_files": id_files, "qp_files": qp_files,
     "candump_dev_zero": candump_dev_zero}[case](tool, data, work)
    if failures:
        print("%d check(s) failed" % len(failures))
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
