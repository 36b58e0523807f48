/* checkpoint.h: models and training checkpoints as safetensors (SPEC section 6): the parameter
 * tables of hdnet_net.h written under their names (optionally prefixed, e.g. "adam.m."), with the
 * format version and configuration in __metadata__; reading checks every name and shape. */
#ifndef HD_CHECKPOINT_H
#define HD_CHECKPOINT_H

#include "model/hdnet_net.h"

#define HD_CHECKPOINT_MAX_META 48

/* One group of tensors to write or read: a table's tensors under PREFIX + name. */
typedef struct hd_tensor_group {
    const hd_param_table *table;
    const char *prefix; /* "" or "adam.m." ... */
    float *data;        /* flat, table->total floats */
} hd_tensor_group;

/* Metadata being assembled for a write (keys and values are copied). */
typedef struct hd_meta {
    int count;
    char keys[HD_CHECKPOINT_MAX_META][32];
    char values[HD_CHECKPOINT_MAX_META][96];
} hd_meta;

void hd_meta_set(hd_meta *m, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Writes tensors and the metadata (plus format, format_version, width and size from cfg, which
 * meta may override) atomically to path. */
hd_status hd_checkpoint_write_tensors(const char *path, const hd_net_config *cfg, const hd_tensor *tensors, int count,
                                      const hd_meta *meta);
/* Writes the groups' tensors and the metadata (plus format, format_version, width and size from
 * cfg) atomically to path. */
hd_status hd_checkpoint_write(const char *path, const hd_net_config *cfg, const hd_tensor_group *groups, int ngroups,
                              const hd_meta *meta);

/* Reads width and size from a file's metadata and checks the format and version. */
hd_status hd_checkpoint_config(const hd_safetensors *st, const char *path, hd_net_config *cfg);
/* Copies every tensor of the group from st, checking presence, shape and finiteness; errors name
 * the file and the tensor. */
hd_status hd_checkpoint_take(const hd_safetensors *st, const char *path, const hd_tensor_group *g);
/* An integer metadata value (fails naming the file and key if absent or malformed). */
hd_status hd_checkpoint_meta_long(const hd_safetensors *st, const char *path, const char *key, long long *v);
/* The same for an unsigned 64-bit value (RNG states, seeds). */
hd_status hd_checkpoint_meta_u64(const hd_safetensors *st, const char *path, const char *key, uint64_t *v);

/* Writes an inference model (HD-Net parameters only). */
hd_status hd_model_write(const char *path, const hd_net_config *cfg, const float *params, long iteration, int stage);

#endif /* HD_CHECKPOINT_H */
