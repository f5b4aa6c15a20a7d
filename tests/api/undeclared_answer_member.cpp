// Must not compile (ctest answer_names): "summ" is not a member of the Check answer's table, and
// AnswerWriter finds each name in its table as the program compiles (evaluator/answers.h).
#include "facespace/evaluator/answers.h"

std::string Misspelled() {
  std::string out;
  facespace::evaluator::AnswerWriter<facespace::evaluator::Answer::kCheck> w(out);
  return w.Number("summ", 0.5).End();
}
