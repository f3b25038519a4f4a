/*
 * Tables of the Cortex-M0 test program: the reference vectors as C data. The definitions are
 * generated at build time by tests/qemu/gen_tables.py into build/qemu/gen/qt_vectors.c.
 */
#ifndef QT_TABLES_H
#define QT_TABLES_H

#include <stddef.h>
#include <stdint.h>

/** One message's codec behind untyped pointers (the generated wrappers call urb_<message>_*). */
typedef struct {
    const char *name;   /**< schema name */
    size_t struct_size; /**< sizeof the C struct */
    size_t max_size;    /**< longest frame */
    int32_t (*encode)(const void *msg, uint8_t *buf, size_t capacity);
    int32_t (*decode)(void *msg, const uint8_t *buf, size_t length);
    /** Copies the implicit members (set before decoding); NULL when the message has none. */
    void (*set_implicit)(void *msg, const void *from);
    /** The schema path of the first member of *got that differs from *want, or NULL. */
    const char *(*compare)(const void *got, const void *want);
} qt_message_t;

/** One vector of tests/vectors/<file>.json. */
typedef struct {
    const qt_message_t *message;
    const uint8_t *frame; /**< the hand-derived frame */
    size_t length;
    const void *fields;   /**< valid: the expected struct; error: its implicit members (or NULL) */
    int32_t error;        /**< 0: a valid vector; else the URB_ERR_* decode must return */
    const char *source;   /**< "<file> #<index>" */
} qt_vector_t;

extern const qt_vector_t qt_vectors[];
extern const size_t qt_vector_count;
/** Decode target, aligned for and at least as large as every message struct in the table. */
extern void *const qt_scratch;
extern const size_t qt_scratch_size;

#endif /* QT_TABLES_H */
