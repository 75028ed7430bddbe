#include "qido_studies.h"

#include <dcmtk/config/osconfig.h>

#include <dcmtk/dcmdata/dcdatset.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>

namespace dicomwebtest {

namespace fs = std::filesystem;

bool makeStudy(const fs::path& boxesFolder, const fs::path& out, const StudySpec& spec, MadeStudy* made,
               std::string* why) {
    fs::remove_all(out);
    fs::create_directories(out);
    char uid[100];
    made->spec = spec;
    made->studyUid = dcmGenerateUniqueIdentifier(uid, SITE_STUDY_UID_ROOT);
    made->seriesUid = dcmGenerateUniqueIdentifier(uid, SITE_SERIES_UID_ROOT);
    made->folder = out;
    for (const char* name : {"boxes_0.dcm", "boxes_1.dcm"}) {
        DcmFileFormat ff;
        if (ff.loadFile(OFFilename((boxesFolder / name).c_str())).bad()) {
            *why = "cannot read " + (boxesFolder / name).string();
            return false;
        }
        DcmDataset* d = ff.getDataset();
        const std::string sop = dcmGenerateUniqueIdentifier(uid, SITE_INSTANCE_UID_ROOT);
        const std::pair<DcmTagKey, std::string> values[] = {
            {DCM_PatientName, spec.patientName},
            {DCM_PatientID, spec.patientId},
            {DCM_AccessionNumber, spec.accessionNumber},
            {DCM_StudyDate, spec.studyDate},
            {DCM_StudyDescription, spec.studyDescription},
            {DCM_SeriesDescription, spec.seriesDescription},
            {DCM_Modality, spec.modality},
            {DCM_StudyInstanceUID, made->studyUid},
            {DCM_SeriesInstanceUID, made->seriesUid},
            {DCM_SOPInstanceUID, sop},
        };
        for (const auto& [tag, value] : values) {
            if (d->putAndInsertString(tag, value.c_str()).bad()) {
                *why = "cannot set " + std::string(DcmTag(tag).getTagName()) + " in " + name;
                return false;
            }
        }
        // EWM_updateMeta: the meta header's Media Storage SOP Instance UID follows the new one.
        if (ff.saveFile(OFFilename((out / name).c_str()), EXS_Unknown, EET_UndefinedLength, EGL_recalcGL, EPD_noChange,
                        0, 0, EWM_updateMeta)
                .bad()) {
            *why = "cannot write " + (out / name).string();
            return false;
        }
    }
    return true;
}

std::vector<StudySpec> standardStudies() {
    std::vector<StudySpec> out;
    for (int i = 1; i <= 8; ++i) {
        StudySpec s;
        const std::string n = std::to_string(i);
        s.patientName = i <= 5 ? "Doe^Jane" + n : i <= 7 ? "Roe^Max" + n : "Doe^John" + n;
        s.patientId = "PID" + n;
        s.accessionNumber = "ACC-" + n;
        s.studyDate = "2024010" + n;
        s.studyDescription = "Slide study " + n;
        s.modality = i <= 7 ? "SM" : "OT";
        s.seriesDescription = "Slide " + n;
        out.push_back(s);
    }
    return out;
}

} // namespace dicomwebtest
