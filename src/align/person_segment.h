/* person_segment.h: where the person is, about a face: MediaPipe's selfie segmentation network run
 * on a square crop posed by the face's mesh fit (person_segment.c; docs/face_detect.md, "Where the
 * person is"). */
#ifndef HD_PERSON_SEGMENT_H
#define HD_PERSON_SEGMENT_H

#include "hdnet.h"

#define HD_PERSON_SIZE 256 /* the network's input and output side */

typedef struct hd_person_segmenter hd_person_segmenter;

/* Loads the network: json_path, or NULL for the shipped face-models/selfie.json (data search
 * path). Refuses a graph whose input is not 256 x 256 x 3 or that has no (1, 256, 256, 1) output. */
hd_status hd_person_segmenter_load(const char *json_path, hd_person_segmenter **segmenter);
void hd_person_segmenter_free(hd_person_segmenter *segmenter);

/* The network on an input of HD_PERSON_SIZE^2 RGB pixels in [0, 1] (interleaved, row-major);
 * *map (HD_PERSON_SIZE^2 probabilities) stays valid until the next run or free. */
hd_status hd_person_segmenter_run(hd_person_segmenter *segmenter, const float *rgb, const float **map);

/* The crop about face f (photo pixels): its top-left corner and side. */
void hd_person_crop(const hd_aligned_face *f, float *x0, float *y0, float *side);

/* Fills face->person (replacing what it held) and its window (person_x0, person_y0): the
 * probability that each pixel of the crop's part of photo (3 channels, the photo the face was
 * aligned in) shows the person. A map that does not see the face (hd_person_map_sees_face) is
 * dropped: face->person is left empty. */
hd_status hd_person_segment(hd_person_segmenter *segmenter, const hd_image *photo, hd_aligned_face *face);

/* 1 if face->person sees the face as the person: a mean probability of at least one half over
 * its landmarks that lie in the map's window. hd_person_segment drops a map that does not (the
 * face keeps no map: face->person.data NULL), and says so by nothing else: no map is no error. */
int hd_person_map_sees_face(const hd_aligned_face *face);

/* to = max(to, face f's map) over the W x H photo f was aligned in, within the map's window; with
 * body, below the window too, where the body goes on: the window's last row carried down (the
 * nearest of its pixels beyond its sides). A face without a map leaves to as it is. */
void hd_person_map_max(const hd_aligned_face *f, int W, int H, int body, float *to);

#endif /* HD_PERSON_SEGMENT_H */
