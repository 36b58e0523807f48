/* safetensors.h: the checkpoint file's lookups and its writer (safetensors.c), for the model's and
 * the trainer's checkpoints, the tool and the tests; reading and freeing a file are public. */
#ifndef HD_IO_SAFETENSORS_H
#define HD_IO_SAFETENSORS_H

#include "hdnet.h"

/* The tensor named name, or NULL. */
const hd_tensor *hd_safetensors_find(const hd_safetensors *st, const char *name);
/* The metadata value for key, or NULL. */
const char *hd_safetensors_meta(const hd_safetensors *st, const char *key);
/* Writes tensors (F32) and string metadata to a temporary file, fsyncs and renames it. */
hd_status hd_safetensors_write(const char *path, const hd_tensor *tensors, int count,
                               const char *const *meta_keys, const char *const *meta_values,
                               int meta_count);

#endif /* HD_IO_SAFETENSORS_H */
