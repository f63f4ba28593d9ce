#!/usr/bin/env python3
"""Lists the functions of the C++ sources over a number of lines (docs/architecture.md, "Function length").

A function is a brace block opened at namespace or class level right after a parameter list; its length counts
its lines from the line of its opening brace's header to its closing brace. Comments and string literals are
blanked first, so braces inside them do not count.
"""
import argparse
import pathlib
import re
import sys


def blank(text):
    """Comments and string/char literals replaced by spaces, newlines kept (line numbers stay)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            out.append(' ' * (j - i))
            i = j
        elif text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if m:
                end = text.find(')' + m.group(1) + '"', i)
                end = n if end < 0 else end + len(m.group(1)) + 2
                out.append(re.sub(r'[^\n]', ' ', text[i:end]))
                i = end
            else:
                out.append(c)
                i += 1
        elif c in '"\'':
            j = i + 1
            while j < n and text[j] != c and text[j] != '\n':
                j += 2 if text[j] == '\\' else 1
            out.append(' ' * (j + 1 - i))
            i = j + 1
        elif c == '#' and (i == 0 or text[i - 1] == '\n' or text[max(0, text.rfind('\n', 0, i)) + 1:i].strip() == ''):
            # a preprocessor line (with its continuations) is no code: an #include must not start a header
            j = i
            while True:
                j = text.find('\n', j)
                if j < 0 or text[j - 1] != '\\':
                    break
                j += 1
            j = n if j < 0 else j
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return ''.join(out)


def functions(path):
    text = blank(path.read_text(encoding='utf-8', errors='replace'))
    stack = []  # (kind, start line, name)
    header_start = 0
    for m in re.finditer(r'[{};]', text):
        c, pos = m.group(), m.start()
        if c == ';':
            header_start = pos + 1
            continue
        if c == '}':
            if stack:
                kind, line, name = stack.pop()
                if kind == 'function':
                    yield name, line, text.count('\n', 0, pos) + 1
            header_start = pos + 1
            continue
        header = text[header_start:pos]
        header_start = pos + 1
        outer = all(k in ('namespace', 'class') for k, _, _ in stack)
        h = ' '.join(header.split())
        if re.search(r'\bnamespace\b', h) or h.startswith('extern "C"'):
            kind = 'namespace'
        elif re.search(r'\b(class|struct|union|enum)\b[^()=]*$', h):
            kind = 'class'
        elif outer and re.search(r'\)\s*(const|override|final|noexcept|mutable|->[^=]*|:[^;]*)?\s*$', h) \
                and not re.search(r'=\s*$', h):
            kind = 'function'
        else:
            kind = 'block'
        name = ''
        if kind == 'function':
            name_m = re.search(r'([~\w:<>]+)\s*\(', h)
            name = name_m.group(1) if name_m else h[:40]
            first = text.count('\n', 0, pos - len(header.lstrip())) + 1
        else:
            first = text.count('\n', 0, pos) + 1
        stack.append((kind, first, name))


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--max', type=int, default=100, help='list functions longer than this many lines')
    ap.add_argument('--allow', action='append', default=[], metavar='FILE:NAME',
                    help='a documented exception (a table kept whole), by file and function name')
    ap.add_argument('--check', action='store_true',
                    help='exit 1 if a function other than the allowed ones is over --max (the ctest)')
    ap.add_argument('dirs', nargs='*', default=['core', 'api', 'server'])
    args = ap.parse_args()
    rows = []
    for d in args.dirs:
        for p in sorted(pathlib.Path(d).rglob('*')):
            if p.suffix in ('.cc', '.h') and p.is_file():
                for name, a, b in functions(p):
                    if b - a + 1 > args.max:
                        rows.append((b - a + 1, f'{p}:{a}', name))
    allowed = {tuple(a.rsplit(':', 1)) for a in args.allow}
    over = []
    for length, where, name in sorted(rows, reverse=True):
        exception = (where.rsplit(':', 1)[0], name) in allowed
        print(f'{length:5d}  {where}  {name}' + ('  (allowed: a table)' if exception else ''))
        if not exception:
            over.append(name)
    print(f'{len(rows)} functions over {args.max} lines in {", ".join(args.dirs)}')
    return 1 if args.check and over else 0


if __name__ == '__main__':
    sys.exit(main())
