/* clip_frames.h: folders of frames, the clip format that needs no FFmpeg (clip_frames.c). */
#ifndef HD_CLIP_FRAMES_H
#define HD_CLIP_FRAMES_H

#include "hdnet.h"

typedef struct hd_frame_list {
    char *dir;
    char **names; /* sorted */
    int count, next;
} hd_frame_list;
hd_status hd_frame_list_open(const char *dir, hd_frame_list *list);
hd_status hd_frame_list_read(hd_frame_list *list, hd_image *frame, int *got);
void hd_frame_list_free(hd_frame_list *list);

typedef struct hd_frame_folder {
    char *dir;
    long written;
} hd_frame_folder;
hd_status hd_frame_folder_create(const char *dir, hd_frame_folder *folder);
hd_status hd_frame_folder_write(hd_frame_folder *folder, const hd_image *frame);
/* ok 0: the frames written are removed. */
void hd_frame_folder_finish(hd_frame_folder *folder, int ok);

#endif /* HD_CLIP_FRAMES_H */
