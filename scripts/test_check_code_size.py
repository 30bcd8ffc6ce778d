#!/usr/bin/python3
"""Unit tests of check_code_size.py's parser on snippets that fool a naive brace counter."""

import contextlib
import io
import os
import sys
import tempfile
import textwrap
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_code_size as ccs  # noqa: E402


def functions(code):
    """{name: body lines} of the functions in `code`."""
    return {f.name: f.lines for f in ccs.find_functions(textwrap.dedent(code))}


def body(n):
    """n statement lines, for a body of n + 2 lines with its braces."""
    return "".join(f"  x += {k};\n" for k in range(n))


class StripTest(unittest.TestCase):
    def test_literals_and_comments_keep_lines(self):
        code = 'a = "{ // }"; /* { */ b = \'{\'; // }\nc = R"x(\n})x";\n'
        stripped = ccs.strip_non_code(code)
        self.assertEqual(stripped.count("\n"), code.count("\n"))
        self.assertNotIn("{", stripped)
        self.assertNotIn("}", stripped)

    def test_escaped_quotes_and_digit_separators(self):
        code = "s = \"\\\"{\"; c = '\\''; n = 1'000'000; d = u8'x'; e = '{';\n"
        stripped = ccs.strip_non_code(code)
        self.assertIn("1'000'000", stripped)
        self.assertNotIn("{", stripped)

    def test_only_the_first_branch_of_a_conditional(self):
        code = "#if A\nvoid f(int a) {\n#else\nvoid f() {\n#endif\n}\n"
        self.assertEqual(functions(code), {"f": 5})


class FunctionTest(unittest.TestCase):
    def test_braces_in_literals_do_not_count(self):
        code = 'void f() {\n  s = "}}}";\n  c = \'}\';\n  // }\n  r = R"(}\n)";\n}\nvoid g() {}\n'
        self.assertEqual(functions(code), {"f": 7, "g": 1})

    def test_control_statements_and_lambdas_are_part_of_the_function(self):
        code = """
        void f() {
          if (a) {
            for (int i = 0; i < 3; ++i) {
            }
          }
          auto g = [&](int x) -> int {
            return x;
          };
          struct Local { void h() {} };
        }
        """
        self.assertEqual(functions(code), {"f": 10})

    def test_classes_and_out_of_class_members(self):
        code = """
        namespace a::b {
        template <typename T, typename = std::enable_if_t<true>>
        class Foo : public Bar<Foo<T>> {
         public:
          Foo() = default;
          int get() const noexcept { return x_; }
          bool operator==(const Foo& o) const { return true; }
          explicit operator bool() const { return true; }
          auto size() const -> std::size_t {
            return 0;
          }
         private:
          int x_{0};
          std::vector<int> v_ = {1, 2};
        };
        template <typename T>
        Result<std::optional<T>> Foo<T>::make(int a, int b) noexcept(false) {
          return {};
        }
        Foo::~Foo() {
        }
        }  // namespace a::b
        """
        self.assertEqual(
            functions(code), {
                "get": 1,
                "operator==": 1,
                "operator bool": 1,
                "size": 3,
                "Foo<T>::make": 3,
                "Foo::~Foo": 2
            })

    def test_constructor_initialiser_lists_with_braces(self):
        code = """
        Foo::Foo(int a, Options o = {})
            : Base<int>(a), x_{a}, v_{1, 2, {3}}, s_(a) {
          run();
        }
        struct S {
          S(int a) : a_{a} {}
          int a_;
        };
        """
        self.assertEqual(functions(code), {"Foo::Foo": 3, "S": 1})

    def test_namespace_scope_lambdas_and_tables(self):
        code = """
        namespace {
        const auto kTwice = [](int x) {
          return 2 * x;
        };
        const std::map<std::string, Fn> kTable = {
            {"a", [](int x) {
               return x;
             }},
        };
        enum class Colour : int { kRed, kGreen };
        }  // namespace
        """
        self.assertEqual(functions(code), {"kTwice": 3, "lambda in kTable": 3})

    def test_macros(self):
        code = """
        CDFF_REGISTER_DFI(EdgeDetectionCanny)

        void after() {
        }
        TEST(Suite, Name) {
          EXPECT_TRUE(true);
        }
        CDFF_SHADING_CLONES void shade(int n) {
        }
        """
        self.assertEqual(functions(code), {"after": 2, "TEST(Suite, Name)": 3, "shade": 2})

    def test_quotes_inside_other_literals(self):
        code = (
            "void f() {\n"
            "  char q = '\"';\n"
            "  char b = '\\\\';\n"
            '  auto r = R"sql(a )" { b)sql";\n'
            '  auto s = "\\"{";\n'
            "}\n"
            "[[nodiscard]] int g() noexcept {\n"
            "  return 0;\n"
            "}\n"
            "struct F {\n"
            "  void operator()(int a) const { }\n"
            "  template <typename T>\n"
            "    requires std::integral<T>\n"
            "  T h(T t) { return t; }\n"
            "};\n")
        self.assertEqual(functions(code), {"f": 6, "g": 3, "operator()": 1, "h": 1})

    def test_extern_c_and_function_try_blocks(self):
        code = """
        extern "C" {
        int c_api(void) { return 0; }
        }
        void f() try {
          g();
        } catch (...) {
        }
        """
        self.assertEqual(functions(code), {"c_api": 1, "f": 3})


class ReportTest(unittest.TestCase):
    def test_function_over_the_limit(self):
        code = "int f() {\n" + body(80) + "}\nint g() {\n" + body(78) + "}\n"
        over, exempt = ccs.check_text("x.cpp", code)
        self.assertEqual(over, ["x.cpp:1: function f is 82 lines (limit 80)"])
        self.assertEqual(exempt, [])

    def test_function_reason(self):
        code = ("// size: one table, read top to bottom\nint f() {\n" + body(90) + "}\n"
                "// size: a reason above the leading comment block\n// What h does.\n"
                "// And why.\nint h() {\n" + body(90) + "}\n"
                "// size: not the next function's reason\n\nint g() {\n" + body(90) + "}\n")
        over, exempt = ccs.check_text("x.cpp", code)
        self.assertEqual(len(exempt), 2)
        self.assertEqual(len(over), 1)
        self.assertIn("function g is 92 lines", over[0])

    def test_file_over_the_limit_and_its_reason(self):
        code = "int a;\n" * 801
        self.assertEqual(ccs.check_text("x.hpp", code)[0], ["x.hpp: 801 lines (limit 800)"])
        reasoned = "// Generated tables.\n// size: one table per opcode\n" + code
        self.assertEqual(ccs.check_text("x.hpp", reasoned), ([], ["x.hpp: 803 lines (limit 800)"]))

    def test_exit_status_and_list_mode(self):
        with tempfile.TemporaryDirectory() as root:
            os.makedirs(os.path.join(root, "src"))
            os.makedirs(os.path.join(root, "dfns"))
            with open(os.path.join(root, "src", "a.cpp"), "w") as f:
                f.write("int f() {\n" + body(81) + "}\n")
            with open(os.path.join(root, "dfns", "b.gen.cpp"), "w") as f:
                f.write("int g() {\n" + body(200) + "}\n")
            out = io.StringIO()
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
                self.assertEqual(ccs.main([root]), 1)
                self.assertEqual(ccs.main([root, "--list"]), 0)
            self.assertIn("src/a.cpp:1: function f is 83 lines (limit 80)", out.getvalue())
            self.assertNotIn("b.gen.cpp", out.getvalue())


if __name__ == "__main__":
    unittest.main()
