/* The expression compiler (expr/parse.c, expr/dag.c): any text is compiled or
 * refused with an error, never a crash.  Two lets are defined first so the
 * input can use names; a compiled tape is evaluated once over a box (its
 * clauses must be well formed for that) and cloned. */
#define _DEFAULT_SOURCE
#include "fuzz_input.h"

#include "expr/tape.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = fuzz_string(data, size);
    tape_compiler_t *tc = tape_compiler_new();
    if (!text || !tc)
        abort();
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (tape_compiler_define(tc, "r2", "x^2 + y^2", &err) ||
        tape_compiler_define(tc, "w", "sin(r2) * z", &err))
        abort();
    tape_t *tape = NULL;
    if (tape_compiler_compile(tc, text, &tape, &err) == 0) {
        if (!tape || tape->n < 1)
            abort();
        tape_ws_t *ws = tape_ws_new(tape->n);
        if (!ws)
            abort();
        const iv_box_t box = {{-1.5, 0.25}, {-0.5, 2}, {0, 1}};
        iv_t out;
        tape_eval_interval(tape, ws, 1, &box, &out);
        tape_ws_free(ws);
        tape_t *copy = tape_clone(tape);
        if (!copy || copy->n != tape->n)
            abort();
        tape_free(copy);
        tape_free(tape);
    } else if (!err.msg[0]) {
        abort(); /* a refusal says why */
    }
    tape_compiler_free(tc);
    free(text);
    return 0;
}
