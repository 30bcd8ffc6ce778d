#!/usr/bin/python3
"""Checks the size of the C++ sources: no file over 800 lines, no function over 80.

Scans *.cpp and *.hpp under src/, dfns/ and python/src/ (generated *.gen.* files aside) and reports

    path: N lines (limit 800)
    path:line: function NAME is N lines (limit 80)

A function's size is the number of lines its body spans, from the line of its opening brace to
the line of its closing brace. Functions are free functions, member functions defined in or out
of their class, lambdas stored in namespace-scope variables and lambdas in namespace-scope
initialisers; a lambda or local class inside a function is part of that function.

A file or a function may stay over the limit with a one-line reason:
  - a file: a line `// size: <reason>` within its first 20 lines;
  - a function: a line `// size: <reason>` just above its signature, or anywhere in the block
    of `//` comments right above it.

Exit status: 0 when nothing is over (or with --list), 1 when something is, 2 on a usage error.
Standard library only: the build runs it with Debian's /usr/bin/python3.
"""

import argparse
import os
import re
import sys

FILE_LIMIT = 80 * 10
FUNCTION_LIMIT = 80
FILE_REASON_LINES = 20
SOURCE_DIRS = ("src", "dfns", "python/src")
EXTENSIONS = (".cpp", ".hpp")

_REASON = re.compile(r"^\s*//+\s*size:\s*\S")
_RAW_PREFIX = re.compile(r"(?:u8|u|U|L)?R")
_CHAR_PREFIX = re.compile(r"(?:u8|u|U|L)")


# --------------------------------------------------------------------------------------------
# Step 1: blank out everything that is not code.
# --------------------------------------------------------------------------------------------
def strip_non_code(text):
    """Returns `text` with comments, string and character literals (raw strings included) and
    preprocessor lines replaced by spaces, newlines kept, so that line numbers stay valid and
    braces and parentheses are only those of the code. Of an #if/#elif/#else chain, only the
    first branch is kept, so that both branches of a conditional signature do not open two
    bodies."""
    out = []
    n = len(text)
    i = 0
    at_line_start = True  # only whitespace since the last newline
    cond_stack = []  # for each open #if: True while in a later (#elif/#else) branch

    def blank(s):
        return "".join("\n" if c == "\n" else " " for c in s)

    def skipping():
        return any(cond_stack)

    while i < n:
        c = text[i]
        if c == "\n":
            out.append(c)
            at_line_start = True
            i += 1
            continue
        if c.isspace():
            out.append(c)
            i += 1
            continue
        if at_line_start and c == "#":
            # A preprocessor directive, with its continuation lines.
            j = i
            while j < n:
                if text[j] == "\n" and text[j - 1] != "\\":
                    break
                if text.startswith("//", j):
                    j = text.find("\n", j)
                    j = n if j < 0 else j
                    break
                if text.startswith("/*", j):
                    k = text.find("*/", j + 2)
                    j = n if k < 0 else k + 2
                    continue
                j += 1
            directive = re.match(r"#\s*(\w*)", text[i:j])
            word = directive.group(1) if directive else ""
            if word in ("if", "ifdef", "ifndef"):
                cond_stack.append(False)
            elif word in ("elif", "else") and cond_stack:
                cond_stack[-1] = True
            elif word == "endif" and cond_stack:
                cond_stack.pop()
            out.append(blank(text[i:j]))
            i = j
            continue
        if skipping():
            # Inside a later branch of a conditional: blank up to the end of the line.
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(text[i:j]))
            i = j
            continue
        at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(text[i:j]))
            i = j
            continue
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(blank(text[i:j]))
            i = j
            continue
        if c == '"':
            word = _word_before(text, i)
            if _RAW_PREFIX.fullmatch(word):
                m = re.match(r'"([^()\\\s]{0,16})\(', text[i:])
                if m:
                    end = text.find(")" + m.group(1) + '"', i + len(m.group(0)))
                    j = n if end < 0 else end + len(m.group(1)) + 2
                    out.append(blank(text[i:j]))
                    i = j
                    continue
            j = _quoted_end(text, i, '"')
            out.append(blank(text[i:j]))
            i = j
            continue
        if c == "'":
            word = _word_before(text, i)
            if word and (word[0].isdigit() or word[0] == ".") and not _CHAR_PREFIX.fullmatch(word):
                out.append(c)  # a digit separator: 1'000'000
                i += 1
                continue
            j = _quoted_end(text, i, "'")
            out.append(blank(text[i:j]))
            i = j
            continue
        out.append(c)
        i += 1
    return "".join(out)


def _word_before(text, i):
    """The run of identifier characters (and dots, for numbers) that ends just before i."""
    j = i
    while j > 0 and (text[j - 1].isalnum() or text[j - 1] in "_.'"):
        j -= 1
    return text[j:i].lstrip("'")


def _quoted_end(text, i, quote):
    """The index just past the literal that opens at text[i] (a quote), escapes honoured. An
    unterminated literal ends at the end of its line."""
    j = i + 1
    n = len(text)
    while j < n:
        ch = text[j]
        if ch == "\\":
            j += 2
            continue
        if ch == quote:
            return j + 1
        if ch == "\n":
            return j
        j += 1
    return n


# --------------------------------------------------------------------------------------------
# Step 2: tokens.
# --------------------------------------------------------------------------------------------
class Token:
    __slots__ = ("text", "line")

    def __init__(self, text, line):
        self.text = text
        self.line = line

    def __repr__(self):
        return f"{self.text}@{self.line}"


_TOKEN = re.compile(
    r"""
    (?P<ident>[A-Za-z_]\w*)
  | (?P<number>\.?\d(?:[eEpP][+-]|[\w.'])*)
  | (?P<punct>::|->\*?|\.\.\.|&&|[=!<>]=|[^\s\w])
    """,
    re.VERBOSE,
)
_OPERATOR_SYMBOL = re.compile(r"\s*(\(\s*\)|\[\s*\]|->\*?|<=>|[-+*/%^&|~!=<>,]+)")


def tokenize(code):
    """Tokens of blanked code. `operator` and its symbol become one token (`operator()`,
    `operator==`), so that the parameter list is the next parenthesis."""
    tokens = []
    line = 1
    pos = 0
    n = len(code)
    while pos < n:
        c = code[pos]
        if c == "\n":
            line += 1
            pos += 1
            continue
        if c.isspace():
            pos += 1
            continue
        m = _TOKEN.match(code, pos)
        text = m.group(0)
        pos = m.end()
        if text == "operator":
            sym = _OPERATOR_SYMBOL.match(code, pos)
            if sym:
                text += re.sub(r"\s+", "", sym.group(1))
                line += code.count("\n", pos, sym.end())
                pos = sym.end()
        tokens.append(Token(text, line))
    return tokens


# --------------------------------------------------------------------------------------------
# Step 3: scopes and function bodies.
# --------------------------------------------------------------------------------------------
# Words that take a parenthesis but never name a function being defined.
_NOT_A_NAME = {
    "if", "for", "while", "switch", "catch", "return", "sizeof", "alignof", "alignas",
    "decltype", "noexcept", "throw", "static_assert", "requires", "__attribute__",
    "__declspec", "typeid", "new", "delete", "co_await", "co_return", "co_yield",
    "void", "bool", "char", "short", "int", "long", "float", "double", "unsigned", "signed",
    "auto", "const", "volatile", "explicit", "asm", "__asm__", "static_cast", "const_cast",
    "reinterpret_cast", "dynamic_cast", "template", "typename", "using",
}
# Words allowed between a function's `)` and its body.
_TAIL_WORDS = {
    "const", "volatile", "override", "final", "mutable", "constexpr", "consteval", "try",
    "&", "&&",
}
_CLASS_WORDS = {"class", "struct", "union"}
_MACRO = re.compile(r"[A-Z][A-Z0-9_]+")
_ACCESS = {"public", "private", "protected", "signals", "slots", "Q_SIGNALS", "Q_SLOTS"}


class Function:
    __slots__ = ("name", "line", "start_line", "open_line", "close_line")

    def __init__(self, name, line, start_line, open_line, close_line):
        self.name = name
        self.line = line  # line of the name
        self.start_line = start_line  # first line of the signature
        self.open_line = open_line
        self.close_line = close_line

    @property
    def lines(self):
        return self.close_line - self.open_line + 1


def _match_forward(tokens, i, open_, close):
    """Index of the token that closes the group opened at tokens[i]."""
    depth = 0
    for j in range(i, len(tokens)):
        t = tokens[j].text
        if t == open_:
            depth += 1
        elif t == close:
            depth -= 1
            if depth == 0:
                return j
    return len(tokens) - 1


def _match_backward(tokens, i, open_, close):
    """Index of the token that opens the group closed at tokens[i]."""
    depth = 0
    for j in range(i, -1, -1):
        t = tokens[j].text
        if t == close:
            depth += 1
        elif t == open_:
            depth -= 1
            if depth == 0:
                return j
    return -1


def _is_ident(text):
    return text[0].isalpha() or text[0] == "_"


class _Parser:
    def __init__(self, tokens):
        self.t = tokens
        self.functions = []

    # -- helpers on a declaration (a list of tokens) -----------------------------------------
    @staticmethod
    def _top_level_parens(decl):
        """(open, close) indices of each parenthesis group at depth 0 of `decl`."""
        groups = []
        i = 0
        while i < len(decl):
            t = decl[i].text
            if t == "(":
                j = _match_forward(decl, i, "(", ")")
                groups.append((i, j))
                i = j + 1
                continue
            if t == "[":
                i = _match_forward(decl, i, "[", "]") + 1
                continue
            i += 1
        return groups

    @staticmethod
    def _name_before(decl, k):
        """The (qualified) name that ends at decl[k], and the index where it starts."""
        parts = []
        j = k
        while j >= 0:
            t = decl[j].text
            if t == ">":
                # template arguments belong to the name only before `::` or the `(`
                if parts and parts[-1] != "::":
                    break
                o = _match_backward(decl, j, "<", ">")
                if o <= 0:
                    break
                parts.append("".join(x.text for x in decl[o:j + 1]))
                j = o - 1
                continue
            if _is_ident(t) or t in ("::", "~"):
                if _is_ident(t) and parts and _is_ident(parts[-1][0]):
                    # two identifiers in a row: the first belongs to the return type,
                    # unless it is `operator` of a conversion function
                    if t != "operator":
                        break
                parts.append(t)
                j -= 1
                continue
            break
        name = ""
        for p in reversed(parts):
            if name and _is_ident(p[0]) and _is_ident(name[-1]):
                name += " "
            name += p
        return name, j + 1

    @staticmethod
    def _tail_state(tail):
        """Reads the tokens between a parameter list's `)` and a `{`. Returns None when they
        cannot sit there, "body" when the `{` opens the body, "member" when it opens a member's
        brace initialiser in a constructor's initialiser list."""
        i = 0
        n = len(tail)
        while i < n:
            t = tail[i].text
            if t in _TAIL_WORDS:
                i += 1
            elif t in ("noexcept", "throw") and i + 1 < n and tail[i + 1].text == "(":
                i = _match_forward(tail, i + 1, "(", ")") + 1
            elif t == "noexcept":
                i += 1
            elif t == "[":
                i = _match_forward(tail, i, "[", "]") + 1
            elif _MACRO.fullmatch(t):
                i += 1  # a macro that expands to a specifier
            elif t == "->":
                # A trailing return type, then perhaps a requires-clause.
                i += 1
                while i < n and tail[i].text not in ("=", ";", ":", "requires"):
                    i += 1
                if i < n and tail[i].text == "requires":
                    return "body"
                if i < n:
                    return None
            elif t == "requires":
                return "body"
            elif t == ":":
                return _Parser._initialiser_list_state(tail[i + 1:])
            else:
                return None
        return "body"

    @staticmethod
    def _initialiser_list_state(items):
        """State after `: a_(x), b_{}` ... (member braces already folded into `{}`)."""
        expect_init = False  # a member's name has been read, its initialiser has not
        i = 0
        n = len(items)
        while i < n:
            t = items[i].text
            if t == "(":
                if not expect_init:
                    return None
                i = _match_forward(items, i, "(", ")") + 1
                expect_init = False
                continue
            if t == "{}":
                if not expect_init:
                    return None
                expect_init = False
            elif t == "<":
                i = _match_forward(items, i, "<", ">") + 1
                continue
            elif _is_ident(t) or t in ("::", "~"):
                expect_init = True
            elif t in (",", "..."):
                pass
            else:
                return None
            i += 1
        return "member" if expect_init else "body"

    def _function_candidate(self, decl):
        """For a declaration followed by `{`: (kind, name, name_index, start_index) where kind
        is "body" or "member", or None when the declaration is not a function's."""
        start = 0
        for open_i, close_i in self._top_level_parens(decl):
            if open_i == 0:
                start = close_i + 1
                continue
            prev = decl[open_i - 1].text
            conversion = open_i >= 2 and decl[open_i - 2].text == "operator"
            name_ok = (_is_ident(prev) and (prev not in _NOT_A_NAME or conversion)
                       ) or prev.startswith("operator") or prev == ">"
            if not name_ok:
                continue
            state = self._tail_state(decl[close_i + 1:])
            if state is None:
                if _is_ident(prev) and prev not in _NOT_A_NAME:
                    start = close_i + 1  # a macro call before the declaration
                continue
            name, name_i = self._name_before(decl, open_i - 1)
            if not name:
                continue
            if _MACRO.fullmatch(name):
                # A macro that defines a function (TEST(a, b) {): its arguments name it.
                name += "(" + " ".join(x.text for x in decl[open_i + 1:close_i]).replace(
                    " ,", ",") + ")"
            return state, name, name_i, start
        return None

    @staticmethod
    def _lambda_start(tokens):
        """When `tokens` end with a lambda's introducer and declarator (a `{` after them opens
        a lambda body), the index of the lambda's `[`; otherwise -1."""
        # walk back over specifiers and a trailing return type
        k = len(tokens) - 1
        while k >= 0 and tokens[k].text not in (")", "]"):
            t = tokens[k].text
            if not (_is_ident(t) or t in ("::", "<", ">", "*", "&", "&&", "->", ",")):
                return -1
            k -= 1
        if k < 0:
            return -1
        if tokens[k].text == ")":
            o = _match_backward(tokens, k, "(", ")")
            if o <= 0:
                return -1
            k = o - 1
            if tokens[k].text == ">":  # []<typename T>(T x)
                k = _match_backward(tokens, k, "<", ">") - 1
        if k < 0 or tokens[k].text != "]":
            return -1
        o = _match_backward(tokens, k, "[", "]")
        if o < 0:
            return -1
        if o > 0 and (_is_ident(tokens[o - 1].text) or tokens[o - 1].text in (")", "]")):
            return -1  # a subscript, not a lambda
        return o

    # -- scopes ----------------------------------------------------------------------------
    def parse(self):
        self._scope(0)
        return self.functions

    def _record(self, name, name_tok, start_tok, open_i):
        close_i = _match_forward(self.t, open_i, "{", "}")
        self.functions.append(
            Function(name, name_tok.line, start_tok.line, self.t[open_i].line,
                     self.t[close_i].line))
        return close_i

    def _scope(self, i):
        """Reads a namespace or class scope from tokens[i] to its closing `}`. Returns the
        index just past it."""
        decl = []
        depth = 0  # parentheses open in the declaration
        t = self.t
        n = len(t)
        while i < n:
            tok = t[i]
            x = tok.text
            if x == "}" and depth == 0:
                return i + 1
            if x == ";" and depth == 0:
                decl = []
                i += 1
                continue
            if x == ":" and depth == 0 and decl and decl[-1].text in _ACCESS:
                decl = []
                i += 1
                continue
            if x == "(":
                depth += 1
            elif x == ")":
                depth = max(0, depth - 1)
            if x != "{":
                decl.append(tok)
                i += 1
                continue
            i = self._open_brace(decl, i, depth)
            if i < 0:  # the brace ended the declaration
                i = -i
                decl = []
            else:
                decl.append(Token("{}", tok.line))
        return n

    def _open_brace(self, decl, i, depth):
        """Handles a `{` at tokens[i] in a namespace or class scope. Returns the index past the
        group, negated when the group ends the declaration (a body or a scope)."""
        t = self.t
        if depth > 0:
            return self._initialiser(decl, i)
        words = [x.text for x in decl]
        if "namespace" in words or words == ["extern"]:
            return -self._scope(i + 1)
        cand = self._function_candidate(decl)
        if cand is not None:
            state, name, name_i, start_i = cand
            if state == "member":
                return self._initialiser([], i)
            return -(self._record(name, decl[name_i], decl[start_i], i) + 1)
        head = self._strip_prefix(decl)
        head_words = [x.text for x in head]
        eq = self._top_level_index(head, "=")
        if eq >= 0:
            rhs = head[eq + 1:]
            if rhs and self._lambda_start(rhs) == 0:
                name, name_i = self._name_before(head, eq - 1)
                first = head[name_i] if name and name_i < len(head) else rhs[0]
                return -(self._record(name or "lambda", first, decl[0], i) + 1)
            return self._initialiser(decl, i)
        if head_words and head_words[0] == "enum":
            return -(_match_forward(t, i, "{", "}") + 1)
        if any(w in _CLASS_WORDS for w in head_words):
            return -self._scope(i + 1)
        return self._initialiser(decl, i)

    @staticmethod
    def _top_level_index(tokens, text):
        """Index of the first `text` outside parentheses, brackets and braces, or -1."""
        depth = 0
        for k, x in enumerate(tokens):
            if x.text in ("(", "[", "{"):
                depth += 1
            elif x.text in (")", "]", "}"):
                depth -= 1
            elif x.text == text and depth == 0:
                return k
        return -1

    @staticmethod
    def _strip_prefix(decl):
        """`decl` without a leading `template <...>`, attributes and storage words."""
        i = 0
        n = len(decl)
        while i < n:
            w = decl[i].text
            if w == "template" and i + 1 < n and decl[i + 1].text == "<":
                i = _match_forward(decl, i + 1, "<", ">") + 1
            elif w == "[":
                i = _match_forward(decl, i, "[", "]") + 1
            elif w in ("typedef", "export", "inline", "static", "constexpr", "extern"):
                i += 1
            else:
                break
        return decl[i:]

    def _initialiser(self, before, i):
        """Reads a braced initialiser (or any other brace that is not a body or scope) from
        tokens[i], recording the bodies of lambdas in it. Returns the index past it."""
        t = self.t
        lam = self._lambda_start(before)
        if lam >= 0:
            name, _ = self._name_before(before, self._assigned_name_index(before, lam))
            label = f"lambda in {name}" if name else "lambda"
            return self._record(label, before[lam], before[lam], i) + 1
        level = []  # tokens of this brace level, for spotting lambdas
        j = i + 1
        n = len(t)
        while j < n:
            x = t[j].text
            if x == "}":
                return j + 1
            if x == "{":
                j = self._initialiser(before + level, j)
                level.append(Token("{}", t[j - 1].line))
                continue
            level.append(t[j])
            j += 1
        return n

    @staticmethod
    def _assigned_name_index(tokens, lam):
        """Index of the name a lambda at tokens[lam] is assigned to or passed with, or -1."""
        for k in range(lam - 1, -1, -1):
            if tokens[k].text == "=" and k > 0:
                return k - 1
        return -1


def find_functions(text):
    """The function bodies in C++ source `text`."""
    return _Parser(tokenize(strip_non_code(text))).parse()


# --------------------------------------------------------------------------------------------
# Step 4: reports.
# --------------------------------------------------------------------------------------------
def _has_reason_above(lines, start_line):
    """True when `// size: <reason>` is on the line above line `start_line` (1-based) or in the
    block of `//` comments right above it."""
    k = start_line - 2
    while k >= 0 and lines[k].lstrip().startswith("//"):
        if _REASON.match(lines[k]):
            return True
        k -= 1
    return False


def check_text(path, text, file_limit=FILE_LIMIT, function_limit=FUNCTION_LIMIT):
    """(over, exempt): lists of report lines for the file `path` with contents `text`."""
    over, exempt = [], []
    lines = text.split("\n")
    count = len(lines) - 1 if text.endswith("\n") else len(lines)
    if count > file_limit:
        msg = f"{path}: {count} lines (limit {file_limit})"
        if any(_REASON.match(l) for l in lines[:FILE_REASON_LINES]):
            exempt.append(msg)
        else:
            over.append(msg)
    for f in find_functions(text):
        if f.lines <= function_limit:
            continue
        msg = f"{path}:{f.line}: function {f.name} is {f.lines} lines (limit {function_limit})"
        if _has_reason_above(lines, f.start_line):
            exempt.append(msg)
        else:
            over.append(msg)
    return over, exempt


def source_files(root, paths):
    """Sorted paths, relative to root, of the sources to check."""
    found = []
    for p in paths:
        full = os.path.join(root, p)
        if os.path.isfile(full):
            found.append(os.path.relpath(full, root))
            continue
        for dirpath, dirnames, filenames in os.walk(full):
            dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and d != "build")
            for name in filenames:
                if name.endswith(EXTENSIONS) and ".gen." not in name:
                    found.append(os.path.relpath(os.path.join(dirpath, name), root))
    return sorted(found)


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Reports C++ files over 800 lines and functions over 80 lines in src/ and "
        "dfns/ that carry no `// size: <reason>` line.")
    parser.add_argument("root", nargs="?",
                        default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                        help="repository root (default: the one holding this script)")
    parser.add_argument("paths", nargs="*",
                        help="files or folders under root to check (default: src dfns)")
    parser.add_argument("--list", action="store_true",
                        help="print everything over the limits and exit 0")
    parser.add_argument("--exempt", action="store_true",
                        help="also print what is over the limits with a reason")
    args = parser.parse_args(argv)
    if not os.path.isdir(args.root):
        parser.error(f"{args.root}: not a folder")
    over_all, exempt_all = [], []
    for rel in source_files(args.root, args.paths or SOURCE_DIRS):
        with open(os.path.join(args.root, rel), encoding="utf-8", errors="replace") as f:
            over, exempt = check_text(rel, f.read())
        over_all += over
        exempt_all += exempt
    for line in over_all:
        print(line)
    if args.exempt:
        for line in exempt_all:
            print(f"{line} [exempt]")
    if over_all:
        print(f"{len(over_all)} over the limits; split them, or give a one-line reason "
              "(`// size: <reason>`, see scripts/check_code_size.py)", file=sys.stderr)
    return 1 if over_all and not args.list else 0


if __name__ == "__main__":
    sys.exit(main())
