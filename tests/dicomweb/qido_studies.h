// Studies for the QIDO-RS suites (tst_qido, tst_server_browser): copies of the two-file
// dicom-boxes series (testdata/slides/unsupported/dicom-boxes, a VOLUME and a THUMBNAIL
// instance that the engine opens) rewritten with DCMTK as a new study and series with the
// patient, accession, date, description and modality the test asks for, and fresh UIDs.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dicomwebtest {

struct StudySpec {
    std::string patientName, patientId, accessionNumber, studyDate, studyDescription;
    std::string modality = "SM";
    std::string seriesDescription = "Slide";
};

struct MadeStudy {
    StudySpec spec;
    std::string studyUid, seriesUid;
    std::filesystem::path folder; // the rewritten files
};

// Writes the copy into `out` (made afresh). False and *why on failure.
bool makeStudy(const std::filesystem::path& boxesFolder, const std::filesystem::path& out, const StudySpec& spec,
               MadeStudy* made, std::string* why);

// The suites' set: studies 1…7 of modality SM (patients Doe^Jane1…5 and Roe^Max6, Roe^Max7,
// PatientID PID<i>, AccessionNumber ACC-<i>, StudyDate 2024010<i>, StudyDescription
// "Slide study <i>") and study 8, Doe^John8, of modality OT.
std::vector<StudySpec> standardStudies();

} // namespace dicomwebtest
