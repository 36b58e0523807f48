/* eval_json.h: internal to src/eval: the one way its JSON reports (metrics.c, photo_eval.c,
 * pair_eval.c) reach a file. */
#ifndef HD_EVAL_JSON_H
#define HD_EVAL_JSON_H

#include "hdnet.h"

/* Writes text (a report's JSON, malloc'ed; NULL: it could not be made, the reason in hd_error)
 * with a final newline to path atomically (a temporary name renamed into place), and frees it. */
hd_status hd_eval_json_write(const char *path, char *text);

#endif /* HD_EVAL_JSON_H */
