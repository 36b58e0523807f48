/* test_pose.h: a head pose as a rotation matrix, for the tests that build posed faces with a known
 * answer (test_align, test_repose). */
#ifndef HD_TEST_POSE_H
#define HD_TEST_POSE_H

#include <math.h>

/* R = Rz(roll) Ry(yaw) Rx(pitch), degrees, row-major. */
static inline void test_pose_rotation(double yaw, double pitch, double roll, double R[9])
{
    const double a = yaw * M_PI / 180, b = pitch * M_PI / 180, c = roll * M_PI / 180;
    const double Rx[9] = {1, 0, 0, 0, cos(b), -sin(b), 0, sin(b), cos(b)};
    const double Ry[9] = {cos(a), 0, sin(a), 0, 1, 0, -sin(a), 0, cos(a)};
    const double Rz[9] = {cos(c), -sin(c), 0, sin(c), cos(c), 0, 0, 0, 1};
    double T[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            T[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) T[3 * i + j] += Ry[3 * i + k] * Rx[3 * k + j];
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            R[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) R[3 * i + j] += Rz[3 * i + k] * T[3 * k + j];
        }
}

#endif /* HD_TEST_POSE_H */
