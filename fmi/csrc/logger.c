/*
 * The importer's fmi2CallbackLogger. FMUs call it printf-style (variadic); stable Rust can call
 * a variadic function but not define one, so this shim formats the message with the C library's
 * vsnprintf and hands the finished text to a Rust sink.
 *
 * componentEnvironment points to a struct whose first member is the sink (fmi2::import).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*fmi2rs_sink)(void *env, const char *instance, int status, const char *category,
                            const char *message);

void fmi2rs_logger(void *env, const char *instance, int status, const char *category,
                   const char *format, ...) {
    if (env == NULL) {
        return;
    }
    fmi2rs_sink sink = *(fmi2rs_sink *)env;
    if (format == NULL) {
        sink(env, instance, status, category, "(null message)");
        return;
    }
    char small[1024];
    va_list args, again;
    va_start(args, format);
    va_copy(again, args);
    int n = vsnprintf(small, sizeof small, format, args);
    va_end(args);
    if (n < 0) {
        sink(env, instance, status, category, format);
    } else if ((size_t)n < sizeof small) {
        sink(env, instance, status, category, small);
    } else {
        char *big = malloc((size_t)n + 1);
        if (big != NULL) {
            vsnprintf(big, (size_t)n + 1, format, again);
            sink(env, instance, status, category, big);
            free(big);
        } else {
            sink(env, instance, status, category, small); /* truncated */
        }
    }
    va_end(again);
}
