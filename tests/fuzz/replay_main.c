/*
 * Replays fuzz inputs through a target's LLVMFuzzerTestOneInput without libFuzzer, so a target can
 * be built by any compiler: `make coverage` (tools/coverage.py) runs the committed corpora
 * (tests/fuzz/corpus/<target>/) on its gcc --coverage and clang MC/DC builds. Each argument is an
 * input file or a directory of them (read in name order, so a replay is deterministic). A broken
 * property aborts inside the target (REQUIRE), which fails the replay; exit 0 otherwise, 2 when an
 * input cannot be read. Prints how many inputs ran.
 */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define REPLAY_MAX_INPUT (1u << 20)

static int replay_file(const char *path)
{
    static uint8_t buf[REPLAY_MAX_INPUT];
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return 2;
    }
    size_t const n = fread(buf, 1u, sizeof buf, f);
    int const too_long = (n == sizeof buf) && (fgetc(f) != EOF);
    fclose(f);
    if (too_long) {
        fprintf(stderr, "replay: %s is longer than %u bytes\n", path, REPLAY_MAX_INPUT);
        return 2;
    }
    (void)LLVMFuzzerTestOneInput(buf, n);
    return 0;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Replays every regular file of `dir` in name order; adds the count to *ran. */
static int replay_dir(const char *dir, unsigned *ran)
{
    DIR *d = opendir(dir);
    if (d == NULL) {
        return -1;
    }
    char **names = NULL;
    size_t count = 0u;
    size_t cap = 0u;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') {
            continue;
        }
        if (count == cap) {
            cap = (cap == 0u) ? 256u : 2u * cap;
            char **grown = realloc(names, cap * sizeof *names);
            if (grown == NULL) {
                closedir(d);
                free(names);
                return 2;
            }
            names = grown;
        }
        size_t const len = strlen(dir) + strlen(e->d_name) + 2u;
        names[count] = malloc(len);
        if (names[count] == NULL) {
            closedir(d);
            return 2;
        }
        snprintf(names[count], len, "%s/%s", dir, e->d_name);
        count++;
    }
    closedir(d);
    qsort(names, count, sizeof *names, by_name);
    int status = 0;
    for (size_t i = 0u; i < count; i++) {
        if ((status == 0) && (replay_file(names[i]) != 0)) {
            status = 2;
        }
        free(names[i]);
        (*ran)++;
    }
    free(names);
    return status;
}

int main(int argc, char **argv)
{
    unsigned ran = 0u;
    for (int i = 1; i < argc; i++) {
        int status = replay_dir(argv[i], &ran);
        if (status < 0) {
            status = replay_file(argv[i]);
            ran++;
        }
        if (status != 0) {
            return status;
        }
    }
    printf("replay: %u inputs\n", ran);
    return 0;
}
