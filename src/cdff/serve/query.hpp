#pragma once
// The query parameters of `cdff serve`'s REST routes (router.cpp): each check's error says which
// parameter, its value and what was expected (a 400 JSON error to the browser).

#include <initializer_list>
#include <map>
#include <string>
#include <string_view>

#include "cdff/types/status.hpp"

namespace cdff::serve {

/// A request's %-decoded query parameters (a key may repeat).
using Query = std::multimap<std::string, std::string>;

/// Ok when every parameter is one of `keys` and none but `repeatable` is given twice; else an
/// error naming the parameter and the expected ones.
Status expectParameters(const Query& query, std::initializer_list<std::string_view> keys,
                        std::string_view repeatable = {});

/// The value of `key`; an error when it is missing or empty (`what`: what it should be).
Result<std::string> requiredText(const Query& query, const std::string& key, const char* what);

/// The number `key` in [lo, hi], `fallback` when absent; an error for text that is not a number
/// or a number out of range (`what`: what it counts).
Result<double> number(const Query& query, const std::string& key, double fallback, double lo,
                      double hi, const char* what);

}  // namespace cdff::serve
