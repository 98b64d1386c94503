"""Response models of the OGC API (OpenAPI documentation and conformance of what we send)."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .jobs.store import JobStatus

__all__ = [
    "BatchInfo",
    "Conformance",
    "JobList",
    "LandingPage",
    "Link",
    "ProblemDetails",
    "ProcessDescription",
    "ProcessList",
    "ProcessSummary",
    "StatusInfo",
]


class Link(BaseModel):
    href: str
    rel: str | None = None
    type: str | None = None
    title: str | None = None


class LandingPage(BaseModel):
    title: str
    description: str
    links: list[Link]


class Conformance(BaseModel):
    conformsTo: list[str]  # noqa: N815 - the OGC name


class ProcessSummary(BaseModel):
    id: str
    title: str
    description: str
    version: str
    keywords: list[str] = []
    jobControlOptions: list[str]  # noqa: N815
    outputTransmission: list[str]  # noqa: N815
    links: list[Link] = []


class ProcessDescription(ProcessSummary):
    inputs: dict[str, dict[str, Any]]
    outputs: dict[str, dict[str, Any]]


class ProcessList(BaseModel):
    processes: list[ProcessSummary]
    links: list[Link]


class StatusInfo(BaseModel):
    """The OGC status document of a job."""

    jobID: str  # noqa: N815
    processID: str  # noqa: N815
    type: Literal["process"] = "process"
    status: JobStatus
    message: str = ""
    created: datetime
    # absent (never null) until they happen, as OGC's statusInfo has them
    started: datetime = Field(default=None, description="absent until the job starts")  # type: ignore[assignment]
    finished: datetime = Field(default=None, description="absent until the job ends")  # type: ignore[assignment]
    updated: datetime
    progress: int = Field(ge=0, le=100)
    attempts: int = 0
    seed: int | None = None
    links: list[Link]


class JobList(BaseModel):
    jobs: list[StatusInfo]
    numberMatched: int  # noqa: N815
    links: list[Link]


class BatchJob(BaseModel):
    jobID: str  # noqa: N815
    status: JobStatus
    progress: int
    links: list[Link]


class BatchInfo(BaseModel):
    batchID: str  # noqa: N815
    processID: str  # noqa: N815
    status: JobStatus
    created: str
    progress: int = Field(ge=0, le=100)
    counts: dict[str, int]
    jobs: list[BatchJob]
    links: list[Link]


class ProblemDetails(BaseModel):
    """RFC 9457 problem details."""

    model_config = ConfigDict(extra="allow")

    type: str
    title: str
    status: int
    detail: str
    instance: str | None = None
    pointer: str | None = None
    errors: list[dict[str, Any]] | None = None
