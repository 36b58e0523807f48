/* cmd_align.c: `hdnet align`: photos -> per face, the aligned texture, mask, coarse normals,
 * landmarks and warp file in the SPEC section 5 layout (one subject folder per photo). */
#include <ctype.h>
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("align", cmd_align, "find the faces in photos and unwarp each into the aligned texture space")

static int has_image_extension(const char *name)
{
    const char *dot = strrchr(name, '.');
    if (!dot || dot == name) return 0;
    char ext[8];
    size_t n = strlen(dot + 1);
    if (n == 0 || n >= sizeof ext) return 0;
    for (size_t i = 0; i <= n; i++) ext[i] = (char)tolower((unsigned char)dot[1 + i]);
    return strcmp(ext, "png") == 0 || strcmp(ext, "jpg") == 0 || strcmp(ext, "jpeg") == 0;
}

static int compare_strings(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Appends the photos of `arg` (a file, or a folder's .png/.jpg/.jpeg files in name order). */
static hd_status collect(const char *arg, char ***list, int *count, int *cap)
{
    char **names = NULL;
    int n = 0, ncap = 0;
    if (hd_is_dir(arg)) {
        DIR *d = opendir(arg);
        if (!d) return hd_fail(HD_ERR_IO, "%s: cannot read the folder", arg);
        struct dirent *e;
        while ((e = readdir(d))) {
            if (e->d_name[0] == '.' || !has_image_extension(e->d_name)) continue;
            if (n == ncap) {
                ncap = ncap ? 2 * ncap : 64;
                char **nn = realloc(names, (size_t)ncap * sizeof *nn);
                if (!nn) break;
                names = nn;
            }
            if (!(names[n] = hd_path_join(arg, e->d_name))) break;
            n++;
        }
        closedir(d);
        if (n > 1) qsort(names, (size_t)n, sizeof *names, compare_strings);
    } else {
        names = malloc(sizeof *names);
        if (names && (names[0] = strdup(arg))) n = 1;
    }
    for (int i = 0; i < n; i++) {
        if (*count == *cap) {
            *cap = *cap ? 2 * *cap : 64;
            char **nl = realloc(*list, (size_t)*cap * sizeof *nl);
            if (!nl) {
                for (int j = i; j < n; j++) free(names[j]);
                free(names);
                return hd_fail(HD_ERR_NOMEM, "out of memory listing %s", arg);
            }
            *list = nl;
        }
        (*list)[(*count)++] = names[i];
    }
    free(names);
    return HD_OK;
}

int cmd_align(int argc, char **argv)
{
    const char *out_dir = NULL;
    int size = 256, quiet = 0;
    const cli_opt opts[] = {
        {"output", 'o', CLI_OPT_STRING, &out_dir, "DIR", "output folder: DIR/<photo name>/face<k>.* (required)"},
        {"size", 0, CLI_OPT_INT, &size, "S", "side of the aligned texture, 16..4096 (default 256)"},
        {"quiet", 'q', CLI_OPT_FLAG, &quiet, NULL, "print only problems"},
        {0},
    };
    cli_cmd_spec spec = {
        "align", "IMG|DIR [IMG|DIR ...] -o DIR [--size S]",
        "Finds every face in each photo (a folder: its .png/.jpg/.jpeg files), fits the canonical face mesh\n"
        "to its 468 landmarks and writes, per face k, into DIR/<photo name>/:\n"
        "  face<k>.png            the face unwarped into the aligned texture space (S x S)\n"
        "  face<k>.mask.png       1 where the texel is on the face and seen by the camera\n"
        "  face<k>.normal.png     coarse normals of the fitted mesh, camera frame, 16 bit\n"
        "  face<k>.landmarks.txt  the 468 landmarks, one 'x y z' per line, photo pixels\n"
        "  face<k>.warp.txt       what `hdnet blend --warp` needs to put a result back into the photo\n"
        "Faces are numbered from 0 by detection score. A photo without a face, or one that cannot be read,\n"
        "is reported and skipped. Exit status: 0 if at least one face was written, 1 if none was (or an\n"
        "output could not be written), 2 for a command-line error.",
        opts, 1, -1};
    char **pos;
    int np, code;
    if (cli_opts_parse(&spec, argc, argv, &pos, &np, &code)) return code;
    if (!out_dir) {
        free(pos);
        return cli_usage_error(&spec, "-o DIR is required");
    }
    if (size < 16 || size > 4096) {
        free(pos);
        return cli_usage_error(&spec, "--size must be in 16..4096, got %d", size);
    }
    char **photos = NULL;
    int nphotos = 0, cap = 0, rc = CLI_EXIT_FAIL;
    hd_aligner *aligner = NULL;
    for (int i = 0; i < np; i++)
        if (collect(pos[i], &photos, &nphotos, &cap)) {
            cli_report("align");
            goto done;
        }
    if (nphotos == 0) {
        fprintf(stderr, "hdnet align: no .png/.jpg/.jpeg photo in the given folder(s)\n");
        goto done;
    }
    int faces_written = 0, no_face = 0, unreadable = 0;
    if (hd_mkdirs(out_dir) || hd_aligner_load(&aligner)) { /* an unwritable -o fails before any work */
        cli_report("align");
        goto done;
    }
    for (int p = 0; p < nphotos; p++) {
        hd_image photo = {0};
        if (hd_image_read_as(photos[p], 3, &photo)) {
            cli_report("align");
            unreadable++;
            continue;
        }
        hd_aligned_face *faces = NULL;
        int count = 0;
        double t0 = hd_seconds();
        hd_status st = hd_aligner_run(aligner, &photo, size, &faces, &count);
        double seconds = hd_seconds() - t0;
        hd_image_free(&photo);
        if (st == HD_ERR_NOTFOUND || (st == HD_OK && count == 0)) {
            fprintf(stderr, "hdnet align: %s: no face found\n", photos[p]);
            no_face++;
            continue;
        }
        if (st) {
            fprintf(stderr, "hdnet align: %s: %s\n", photos[p], hd_error());
            unreadable++;
            continue;
        }
        char *stem = hd_path_stem(photos[p]);
        char *dir = stem ? hd_path_join(out_dir, stem) : NULL;
        st = dir ? hd_mkdirs(dir) : HD_ERR_NOMEM;
        for (int k = 0; k < count && st == HD_OK; k++) {
            char name[32];
            snprintf(name, sizeof name, "face%d", k);
            st = hd_aligned_face_write(&faces[k], dir, name);
            if (st == HD_OK) faces_written++;
            if (st == HD_OK && !quiet)
                printf("%s: face %d score %.2f box %.0f,%.0f-%.0f,%.0f fit rms %.2f px -> %s/%s.*\n", photos[p], k,
                       faces[k].score, faces[k].box[0], faces[k].box[1], faces[k].box[2], faces[k].box[3],
                       faces[k].fit_rms, dir, name);
        }
        if (st == HD_OK && !quiet) printf("%s: %d face(s) in %.2f s\n", photos[p], count, seconds);
        free(stem);
        free(dir);
        hd_aligned_faces_free(faces, count);
        if (st) { /* an output that cannot be written stops the batch */
            cli_report("align");
            goto done;
        }
    }
    if (!quiet || faces_written == 0)
        fprintf(faces_written ? stdout : stderr, "%s%d face(s) from %d photo(s) into %s (%d without a face, %d failed)\n",
                faces_written ? "" : "hdnet align: ", faces_written, nphotos, out_dir, no_face, unreadable);
    rc = faces_written > 0 ? CLI_EXIT_OK : CLI_EXIT_FAIL;
done:
    hd_aligner_free(aligner);
    for (int i = 0; i < nphotos; i++) free(photos[i]);
    free(photos);
    free(pos);
    return rc;
}
