// indicial/fitter/did_you_mean.hpp -- the edit distance behind every "did you mean" hint (an
// unknown subcommand, a missing CSV column).
//
//   if (indicial::edit_distance("fitt", "fit", indicial::LetterCase::significant) <= 2) ...
//
// Warnings
// 1. Levenshtein distance (insert, delete, substitute; each costs 1), O(|a| |b|) time: meant
//    for names, not text.
// 2. LetterCase::ignored compares ASCII letters case-insensitively ("cm" is 0 from "Cm").
#pragma once

#include <cstddef>
#include <string>

namespace indicial {

enum class LetterCase { significant, ignored };

std::size_t edit_distance(const std::string& a, const std::string& b, LetterCase letter_case);

}  // namespace indicial
