#!/usr/bin/env python3
"""Counts the data members of a C++ class defined in one file (the class-size figures of docs/AGENT.md).

Usage: tools/class_members.py FILE CLASS [--names]
  FILE   a header or source that defines CLASS (e.g. robot_agent/src/robot_agent.cpp)
  CLASS  the name as it appears after `class` (e.g. RobotAgent::Impl)
Prints the number of data members (non-static; one per declarator, so `a_, b_;` counts two) and, with --names,
their names. A textual count: comments are dropped, member functions (a '(' before any initializer), nested
types, using-declarations and static members are not members. Exit status 2 when the class is not found.
"""
import re
import sys


def members(text, cls):
    start = re.search(r'\b(class|struct)\s+' + re.escape(cls) + r'\b[^;{]*\{', text)
    if not start:
        return None
    text = re.sub(r'//[^\n]*', '', text)
    start = re.search(r'\b(class|struct)\s+' + re.escape(cls) + r'\b[^;{]*\{', text)
    depth, stmt, stmts = 0, '', []
    for c in text[start.end():]:
        if c == '{':
            depth += 1
            stmt += c
        elif c == '}':
            if depth == 0:
                break  # the class's closing brace
            depth -= 1
            stmt += c
            head = stmt.split('{')[0]
            if depth == 0 and ('(' in head or re.match(r'\s*(struct|class|enum|union)\b', stmt)):
                stmts.append('')  # a function body or a nested type ends the statement
                stmt = ''
        elif c == ';' and depth == 0:
            stmts.append(stmt)
            stmt = ''
        else:
            stmt += c
    names = []
    for st in stmts:
        t = re.sub(r'^\s*((public|private|protected)\s*:\s*)+', '', ' '.join(st.split()))
        if not t or re.match(r'(struct|class|enum|union|using|friend|typedef|static)\b', t):
            continue
        head = t.split('{')[0].split('=')[0]
        if '(' in head or 'operator' in head:
            continue
        decl = t
        while re.search(r'<[^<>]*>', decl):
            decl = re.sub(r'<[^<>]*>', '', decl)
        while re.search(r'\{[^{}]*\}', decl):
            decl = re.sub(r'\{[^{}]*\}', '', decl)
        decl = re.sub(r'\([^()]*\)', '', decl)
        decl = re.sub(r'=[^,]*', '', decl)
        parts = decl.split(',')
        names.append(parts[0].split()[-1].strip('*&'))
        names.extend(p.strip().strip('*&') for p in parts[1:])
    return names


def main():
    args = [a for a in sys.argv[1:] if a != '--names']
    if len(args) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    with open(args[0]) as f:
        names = members(f.read(), args[1])
    if names is None:
        print(f'{args[0]}: class {args[1]} not found', file=sys.stderr)
        return 2
    print(len(names))
    if '--names' in sys.argv:
        print(' '.join(names))
    return 0


if __name__ == '__main__':
    sys.exit(main())
