/*
 * The FMI 2.0 logger callback (fmi2CallbackLogger) is C-variadic, which
 * stable Rust cannot define. This shim formats the printf-style message with
 * vsnprintf and hands the finished string to the Rust function
 * host_fmi2_log_message (fmi2-import/src/logger.rs).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

void host_fmi2_log_message(void *env, const char *instance, int status, const char *category,
                           const char *message);

void host_fmi2_logger(void *env, const char *instance, int status, const char *category,
                      const char *format, ...) {
    char stack_buf[1024];
    va_list args;
    if (format == NULL) {
        host_fmi2_log_message(env, instance, status, category, "(null message)");
        return;
    }
    va_start(args, format);
    int n = vsnprintf(stack_buf, sizeof stack_buf, format, args);
    va_end(args);
    if (n < 0) {
        host_fmi2_log_message(env, instance, status, category, format);
        return;
    }
    if ((size_t)n < sizeof stack_buf) {
        host_fmi2_log_message(env, instance, status, category, stack_buf);
        return;
    }
    char *heap = malloc((size_t)n + 1);
    if (heap == NULL) {
        host_fmi2_log_message(env, instance, status, category, stack_buf);
        return;
    }
    va_start(args, format);
    vsnprintf(heap, (size_t)n + 1, format, args);
    va_end(args);
    host_fmi2_log_message(env, instance, status, category, heap);
    free(heap);
}
