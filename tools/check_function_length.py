#!/usr/bin/env python3
"""Lists C++ functions longer than a limit in the given folders; fails when one is not allow-listed.

    tools/check_function_length.py [--max 80] [--root DIR] [--all] FOLDER...

A function's length is the number of lines from the line its name is on to the line of its closing
brace. Functions are found by brace matching after comments, string and character literals and
preprocessor lines are blanked out: a `{` at namespace, class or extern "C" level whose header (the
text since the previous `;`, `{` or `}`) has a parameter list and is not a class, enum, namespace or an
initializer opens a function body (free functions, member functions defined in or out of their class,
constructors, operators, TEST() bodies). Lambdas and local classes count towards the function holding
them.

Exit status: 0 when every long function is in ALLOWED below, 1 when one is not or when an ALLOWED entry
no longer names a long function (the list stays true), 2 on bad usage. --all lists every function over
the limit, allowed or not.
"""
import argparse
import os
import re
import sys

# Functions allowed over the limit: "path relative to the root::qualified name" -> why. The rule of the
# flight core is functions of at most ~80 lines; an entry here must say why this one reads better whole.
ALLOWED = {
}

SOURCE_EXTENSIONS = (".h", ".hpp", ".cpp", ".cc")
NOT_FUNCTION = re.compile(r"(namespace|class|struct|union|enum)\b")
CONTROL = re.compile(r"^\s*(if|for|while|switch|do|else|try|catch|return)\b")


def blank_out(text):
    """The text with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if c == "\n":
            out.append(c)
            i += 1
            at_line_start = True
            continue
        if at_line_start and c == "#" or (at_line_start and c in " \t" and text[i:].lstrip(" \t").startswith("#")):
            # a preprocessor line, with its continuations
            while i < n:
                if text[i] == "\n":
                    if i > 0 and text[i - 1] == "\\":
                        out.append("\n")
                        i += 1
                        continue
                    break
                out.append(" ")
                i += 1
            continue
        at_line_start = False
        if text.startswith("//", i):
            while i < n and text[i] != "\n":
                out.append(" ")
                i += 1
            continue
        if text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
            continue
        raw = re.match(r'R"([^(\s]*)\(', text[i:i + 20])
        if raw and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            close = ")" + raw.group(1) + '"'
            end = text.find(close, i + raw.end())
            end = n if end < 0 else end + len(close)
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
            continue
        # a quote after a digit or letter is a digit separator (1'000) or part of a prefix, not a literal
        if c == '"' or (c == "'" and not (i > 0 and (text[i - 1].isalnum() or text[i - 1] == "_"))):
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(" " * (min(j + 1, n) - i))
            i = j + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


def strip_template_prefix(h):
    """The header without a leading template<...> (angle brackets matched)."""
    while h.startswith("template"):
        start = h.find("<")
        if start < 0:
            return h
        depth = 0
        for j in range(start, len(h)):
            depth += h[j] == "<"
            depth -= h[j] == ">"
            if depth == 0:
                h = h[j + 1:].lstrip()
                break
        else:
            return h
    return h


def is_function_header(header):
    h = strip_template_prefix(" ".join(header.split()))
    if "(" not in h or NOT_FUNCTION.match(h) or CONTROL.match(h) or h.startswith("extern"):
        return False
    if "operator" not in h:
        depth = 0
        for ch in h:  # an '=' outside parentheses makes it an initializer
            depth += ch == "("
            depth -= ch == ")"
            if ch == "=" and depth == 0:
                return False
    return True


def function_name(header):
    h = " ".join(header.split())
    m = re.search(r"(operator\s*\S+?|~?[A-Za-z_][\w:<>~,\s]*?)\s*\(", h)
    name = m.group(1) if m else h[:40]
    return name.split()[-1] if " " in name and not name.startswith("operator") else name


def functions(path):
    """(name, first line, last line) of every function body in the file."""
    with open(path, encoding="utf-8", errors="replace") as f:
        text = blank_out(f.read())
    found = []
    stack = []  # per open brace: "function", "scope" (namespace/class/extern) or "block"
    header_start = 0
    for i, c in enumerate(text):
        if c == ";" and (not stack or stack[-1][0] == "scope"):
            header_start = i + 1
        if c == "{":
            if not stack or stack[-1][0] == "scope":
                header = text[header_start:i]
                if is_function_header(header):
                    offset = len(header) - len(header.lstrip())
                    first = text.count("\n", 0, header_start + offset) + 1
                    stack.append(("function", function_name(header), first))
                elif NOT_FUNCTION.search(header) or "extern" in header or not header.strip():
                    stack.append(("scope", None, 0))
                else:
                    stack.append(("block", None, 0))
                header_start = i + 1
            else:
                stack.append(("block", None, 0))
        elif c == "}":
            if not stack:
                continue
            kind, name, first = stack.pop()
            if kind == "function":
                found.append((name, first, text.count("\n", 0, i) + 1))
            if not stack or stack[-1][0] == "scope":
                header_start = i + 1
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folders", nargs="+")
    parser.add_argument("--max", type=int, default=80, help="longest allowed function, lines (80)")
    parser.add_argument("--root", default=".", help="paths in ALLOWED are relative to this (.)")
    parser.add_argument("--all", action="store_true", help="list every long function, allowed or not")
    args = parser.parse_args()
    long_functions = []
    for folder in args.folders:
        top = os.path.join(args.root, folder)
        if not os.path.isdir(top):
            print(f"check_function_length: no folder {top}", file=sys.stderr)
            return 2
        for dirpath, dirnames, filenames in os.walk(top):
            dirnames.sort()
            for name in sorted(filenames):
                if not name.endswith(SOURCE_EXTENSIONS):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, args.root)
                for fn, first, last in functions(path):
                    length = last - first + 1
                    if length > args.max:
                        long_functions.append((rel, fn, first, length))
    failed = False
    seen = set()
    for rel, fn, first, length in long_functions:
        key = f"{rel}::{fn}"
        seen.add(key)
        if key in ALLOWED:
            if args.all:
                print(f"{rel}:{first}: {fn} is {length} lines (allowed: {ALLOWED[key]})")
            continue
        failed = True
        print(f"{rel}:{first}: {fn} is {length} lines, over {args.max}: split it into named steps, "
              f"or add '{key}' with the reason to ALLOWED in {os.path.relpath(__file__, args.root)}")
    scanned = tuple(os.path.normpath(f) + os.sep for f in args.folders)
    for key in sorted(ALLOWED):
        if key.split("::")[0].startswith(scanned) and key not in seen:
            failed = True
            print(f"ALLOWED names {key}, which is not over {args.max} lines (or no longer exists): remove it")
    print(f"check_function_length: {len(long_functions)} function(s) over {args.max} lines in "
          f"{' '.join(args.folders)}; {'FAILED' if failed else 'ok'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
